// Batch transforms. Every output is computed by the kernels of detail/kernels.hpp: interior outputs read the
// signal in place, outputs near an edge read a small buffer holding the mode's extension, so the edge code is
// short and the interior is a straight loop.
#include "dsp/wavelet.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <stdexcept>

#include "dsp/detail/kernels.hpp"
#include "dsp/detail/transform.hpp"

namespace guideway::dsp {

namespace {

std::ptrdiff_t floor_mod(std::ptrdiff_t k, std::ptrdiff_t p) {
  const std::ptrdiff_t r = k % p;
  return r < 0 ? r + p : r;
}

const detail::Kernels& kernels_checked(const Wavelet& w) {
  const auto& k = detail::kernels_for(w.filter_length());
  if (k.analysis == nullptr)
    throw std::invalid_argument("wavelet " + std::string(w.name()) + ": unsupported filter length");
  return k;
}

constexpr std::size_t kEdgeChunk = 32;                    // outputs per edge-buffer pass
constexpr std::size_t kEdgeBuffer = 2 * kEdgeChunk + 80;  // room for 2*chunk + F - 2 samples, F <= 40

}  // namespace

namespace detail {

double extended_value(std::span<const double> x, std::ptrdiff_t k, Mode mode) {
  const auto n = static_cast<std::ptrdiff_t>(x.size());
  if (k >= 0 && k < n) return x[static_cast<std::size_t>(k)];
  switch (mode) {
    case Mode::zero:
      return 0.0;
    case Mode::constant:
      return k < 0 ? x.front() : x.back();
    case Mode::symmetric: {
      const std::ptrdiff_t r = floor_mod(k, 2 * n);
      return x[static_cast<std::size_t>(r < n ? r : 2 * n - 1 - r)];
    }
    case Mode::reflect: {
      if (n == 1) return x.front();
      const std::ptrdiff_t r = floor_mod(k, 2 * n - 2);
      return x[static_cast<std::size_t>(r < n ? r : 2 * n - 2 - r)];
    }
    case Mode::periodic:
      return x[static_cast<std::size_t>(floor_mod(k, n))];
    case Mode::periodization: {
      // The signal padded to even length with its last sample, repeated.
      const std::ptrdiff_t np = n + (n % 2);
      const std::ptrdiff_t r = floor_mod(k, np);
      return r < n ? x[static_cast<std::size_t>(r)] : x.back();
    }
  }
  return 0.0;
}

void analysis_level(std::span<const double> x, const Wavelet& w, Mode mode, double* a, double* d) {
  const auto& kern = kernels_checked(w);
  const std::size_t f = w.filter_length();
  const std::size_t n_out = dwt_coeff_len(x.size(), f, mode);
  const auto F = static_cast<std::ptrdiff_t>(f);
  const auto N = static_cast<std::ptrdiff_t>(x.size());
  // Output o's window starts at 2o + shift (signal index).
  const std::ptrdiff_t shift = mode == Mode::periodization ? 1 - F / 2 : 2 - F;
  const auto no = static_cast<std::ptrdiff_t>(n_out);
  const std::ptrdiff_t o_lo = std::min<std::ptrdiff_t>((-shift + 1) / 2, no);  // first interior output
  const std::ptrdiff_t last = N - F - shift;                                   // interior needs 2o <= last
  std::ptrdiff_t o_hi = last >= 0 ? std::min<std::ptrdiff_t>(last / 2 + 1, no) : 0;
  o_hi = std::max(o_hi, o_lo);
  const double* lo = w.dec_lo().data();
  const double* hi = w.dec_hi().data();
  std::array<double, kEdgeBuffer> buf{};
  auto edge = [&](std::ptrdiff_t o0, std::ptrdiff_t o1) {
    while (o0 < o1) {
      const std::ptrdiff_t cnt = std::min<std::ptrdiff_t>(o1 - o0, kEdgeChunk);
      const std::ptrdiff_t start = 2 * o0 + shift;
      for (std::ptrdiff_t i = 0; i < 2 * cnt + F - 2; ++i)
        buf[static_cast<std::size_t>(i)] = extended_value(x, start + i, mode);
      kern.analysis(buf.data(), static_cast<std::size_t>(cnt), lo, hi, a + o0, d + o0);
      o0 += cnt;
    }
  };
  edge(0, o_lo);
  if (o_hi > o_lo) {
    kern.analysis(x.data() + (2 * o_lo + shift), static_cast<std::size_t>(o_hi - o_lo), lo, hi, a + o_lo, d + o_lo);
  }
  edge(o_hi, no);
}

// y[s] for s in [2 m0, 2 m1) of the synthesis of the virtual bands C(k) = band[(k - q) mod n] (periodization).
static void synth_periodized(const double* ca, const double* cd, std::size_t n, const Wavelet& w, const double* ga,
                             const double* gd, std::size_t m0, std::size_t m1, double* dst) {
  const auto& kern = kernels_checked(w);
  const auto H = static_cast<std::ptrdiff_t>(w.filter_length() / 2);
  const std::ptrdiff_t q = (H % 2 == 1) ? (H - 1) / 2 : H / 2 - 1;
  const auto nn = static_cast<std::ptrdiff_t>(n);
  // Interior: k - q in [0, n) for k in [m, m + H - 1].
  const std::ptrdiff_t i_lo =
      std::clamp<std::ptrdiff_t>(q, static_cast<std::ptrdiff_t>(m0), static_cast<std::ptrdiff_t>(m1));
  std::ptrdiff_t i_hi =
      std::clamp<std::ptrdiff_t>(nn - H + q + 1, static_cast<std::ptrdiff_t>(m0), static_cast<std::ptrdiff_t>(m1));
  i_hi = std::max(i_hi, i_lo);
  std::array<double, kEdgeBuffer> ba{};
  std::array<double, kEdgeBuffer> bd{};
  auto run = [&](const double* pa, const double* pd, std::size_t cnt, double* out) {
    if (cd != nullptr) {
      kern.synthesis2(pa, pd, cnt, ga, gd, out);
    } else {
      kern.synthesis1(pa, cnt, ga, out);
    }
  };
  auto edge = [&](std::ptrdiff_t e0, std::ptrdiff_t e1) {
    while (e0 < e1) {
      const std::ptrdiff_t cnt = std::min<std::ptrdiff_t>(e1 - e0, kEdgeChunk);
      for (std::ptrdiff_t i = 0; i < cnt + H - 1; ++i) {
        const auto src = static_cast<std::size_t>(floor_mod(e0 + i - q, nn));
        ba[static_cast<std::size_t>(i)] = ca[src];
        if (cd != nullptr) bd[static_cast<std::size_t>(i)] = cd[src];
      }
      run(ba.data(), bd.data(), static_cast<std::size_t>(cnt), dst + 2 * (e0 - static_cast<std::ptrdiff_t>(m0)));
      e0 += cnt;
    }
  };
  edge(static_cast<std::ptrdiff_t>(m0), i_lo);
  if (i_hi > i_lo) {
    run(ca + (i_lo - q), cd != nullptr ? cd + (i_lo - q) : nullptr, static_cast<std::size_t>(i_hi - i_lo),
        dst + 2 * (i_lo - static_cast<std::ptrdiff_t>(m0)));
  }
  edge(i_hi, static_cast<std::ptrdiff_t>(m1));
}

void synthesis_level(const double* ca, const double* cd, std::size_t n, const Wavelet& w, Mode mode, bool ca_is_detail,
                     double* out, std::size_t n_out) {
  const auto& kern = kernels_checked(w);
  const std::size_t f = w.filter_length();
  const double* ga = ca_is_detail ? w.rec_hi().data() : w.rec_lo().data();
  const double* gd = w.rec_hi().data();
  std::array<double, 2> tail{};
  if (mode != Mode::periodization) {
    const std::size_t pairs = n_out / 2;
    if (cd != nullptr) {
      kern.synthesis2(ca, cd, pairs, ga, gd, out);
      if (n_out % 2 == 1) kern.synthesis2(ca + pairs, cd + pairs, 1, ga, gd, tail.data());
    } else {
      kern.synthesis1(ca, pairs, ga, out);
      if (n_out % 2 == 1) kern.synthesis1(ca + pairs, 1, ga, tail.data());
    }
    if (n_out % 2 == 1) out[n_out - 1] = tail[0];
    return;
  }
  const std::size_t h = f / 2;
  if (h % 2 == 1) {  // out[t] = y[t]
    const std::size_t pairs = n_out / 2;
    synth_periodized(ca, cd, n, w, ga, gd, 0, pairs, out);
    if (n_out % 2 == 1) {
      synth_periodized(ca, cd, n, w, ga, gd, pairs, pairs + 1, tail.data());
      out[n_out - 1] = tail[0];
    }
    return;
  }
  // out[t] = y[t - 1], out[0] = y[2n - 1]: PyWavelets shifts the output by one for even F/2.
  if (n_out == 0) return;
  const std::size_t pairs = (n_out - 1) / 2;
  synth_periodized(ca, cd, n, w, ga, gd, 0, pairs, out + 1);
  if ((n_out - 1) % 2 == 1) {
    synth_periodized(ca, cd, n, w, ga, gd, pairs, pairs + 1, tail.data());
    out[n_out - 1] = tail[0];
  }
  synth_periodized(ca, cd, n, w, ga, gd, n - 1, n, tail.data());
  out[0] = tail[1];
}

}  // namespace detail

// ---------------------------------------------------------------------------------------------------------------

Wavelet::Wavelet(std::string_view name) : data_(nullptr) {
  const std::string_view lookup = name == "haar" ? std::string_view("db1") : name;
  for (std::size_t i = 0; i < detail::kFilterBankCount; ++i) {
    if (lookup == detail::kFilterBanks[i].name) {
      data_ = &detail::kFilterBanks[i];
      return;
    }
  }
  throw std::invalid_argument("unknown wavelet '" + std::string(name) +
                              "' (known: db1..db20, haar, sym2..sym20, coif1..coif5)");
}

std::vector<std::string> Wavelet::names() {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < detail::kFilterBankCount; ++i) out.emplace_back(detail::kFilterBanks[i].name);
  return out;
}

namespace {
constexpr std::array<std::pair<Mode, std::string_view>, 6> kModes{{{Mode::zero, "zero"},
                                                                   {Mode::constant, "constant"},
                                                                   {Mode::symmetric, "symmetric"},
                                                                   {Mode::periodic, "periodic"},
                                                                   {Mode::reflect, "reflect"},
                                                                   {Mode::periodization, "periodization"}}};
}  // namespace

Mode parse_mode(std::string_view name) {
  for (const auto& [m, s] : kModes) {
    if (s == name) return m;
  }
  throw std::invalid_argument("unknown signal extension mode '" + std::string(name) +
                              "' (known: zero, constant, symmetric, periodic, reflect, periodization)");
}

std::string_view mode_name(Mode mode) {
  for (const auto& [m, s] : kModes) {
    if (m == mode) return s;
  }
  return "?";
}

std::vector<std::string> mode_names() {
  std::vector<std::string> out;
  for (const auto& [m, s] : kModes) out.emplace_back(s);
  return out;
}

std::size_t dwt_coeff_len(std::size_t signal_length, std::size_t filter_length, Mode mode) {
  if (signal_length == 0) return 0;
  if (mode == Mode::periodization) return (signal_length + 1) / 2;
  return (signal_length + filter_length - 1) / 2;
}

int dwt_max_level(std::size_t signal_length, std::size_t filter_length) {
  if (filter_length <= 1 || signal_length < filter_length - 1) return 0;
  std::size_t q = signal_length / (filter_length - 1);
  int level = 0;
  while (q > 1) {
    q /= 2;
    ++level;
  }
  return level;
}

std::size_t idwt_len(std::size_t coeff_length, std::size_t filter_length, Mode mode) {
  if (mode == Mode::periodization) return 2 * coeff_length;
  if (2 * coeff_length + 2 < filter_length) return 0;
  return 2 * coeff_length + 2 - filter_length;
}

DwtBands dwt(std::span<const double> x, const Wavelet& wavelet, Mode mode) {
  if (x.empty()) throw std::invalid_argument("dwt: empty signal");
  const std::size_t n = dwt_coeff_len(x.size(), wavelet.filter_length(), mode);
  DwtBands out{std::vector<double>(n), std::vector<double>(n)};
  detail::analysis_level(x, wavelet, mode, out.approx.data(), out.detail.data());
  return out;
}

std::vector<double> idwt(std::span<const double> approx, std::span<const double> detail, const Wavelet& wavelet,
                         Mode mode) {
  if (approx.size() != detail.size()) {
    throw std::invalid_argument("idwt: approximation and detail lengths differ (" + std::to_string(approx.size()) +
                                " vs " + std::to_string(detail.size()) + ")");
  }
  const std::size_t n = approx.size();
  if (n == 0) throw std::invalid_argument("idwt: empty coefficients");
  if (mode != Mode::periodization && n < wavelet.filter_length() / 2) {
    throw std::invalid_argument("idwt: " + std::to_string(n) + " coefficients are fewer than half the filter length");
  }
  std::vector<double> out(idwt_len(n, wavelet.filter_length(), mode));
  detail::synthesis_level(approx.data(), detail.data(), n, wavelet, mode, false, out.data(), out.size());
  return out;
}

Coefficients wavedec(std::span<const double> x, const Wavelet& wavelet, Mode mode, int level) {
  WaveletPlan plan(wavelet, mode, x.size(), level);
  std::vector<double> packed(plan.coeff_count());
  plan.decompose(x, packed);
  Coefficients out(plan.band_count());
  for (std::size_t b = 0; b < plan.band_count(); ++b) {
    const auto first = packed.begin() + static_cast<std::ptrdiff_t>(plan.band_offset(b));
    out[b].assign(first, first + static_cast<std::ptrdiff_t>(plan.band_length(b)));
  }
  return out;
}

std::vector<double> waverec(const Coefficients& coeffs, const Wavelet& wavelet, Mode mode) {
  if (coeffs.empty()) throw std::invalid_argument("waverec: no coefficient bands");
  for (std::size_t b = 0; b < coeffs.size(); ++b) {
    if (coeffs[b].empty()) throw std::invalid_argument("waverec: band " + std::to_string(b) + " is empty");
  }
  std::vector<double> a = coeffs[0];
  std::vector<double> next;
  for (std::size_t b = 1; b < coeffs.size(); ++b) {
    const auto& d = coeffs[b];
    if (a.size() == d.size() + 1) {
      a.pop_back();
    } else if (a.size() != d.size()) {
      throw std::invalid_argument("waverec: coefficient shape mismatch at band " + std::to_string(b) + " (" +
                                  std::to_string(a.size()) + " approximation vs " + std::to_string(d.size()) +
                                  " detail coefficients)");
    }
    next = idwt(a, d, wavelet, mode);
    a.swap(next);
  }
  return a;
}

std::vector<std::vector<double>> mra(std::span<const double> x, const Wavelet& wavelet, Mode mode, int level) {
  WaveletPlan plan(wavelet, mode, x.size(), level);
  std::vector<double> packed(plan.coeff_count());
  plan.decompose(x, packed);
  std::vector<std::vector<double>> out(plan.band_count(), std::vector<double>(x.size()));
  for (std::size_t b = 0; b < plan.band_count(); ++b) plan.component(packed, b, out[b]);
  return out;
}

// ---------------------------------------------------------------------------------------------------------------

WaveletPlan::WaveletPlan(const Wavelet& wavelet, Mode mode, std::size_t signal_length, int level)
    : wavelet_(wavelet), mode_(mode), level_(level) {
  if (signal_length == 0) throw std::invalid_argument("wavelet transform of an empty signal");
  (void)kernels_checked(wavelet);
  const std::size_t f = wavelet.filter_length();
  if (level_ < 0) level_ = dwt_max_level(signal_length, f);
  if (level_ > 64) throw std::invalid_argument("wavelet level " + std::to_string(level) + " is too deep");
  n_.push_back(signal_length);
  std::size_t biggest = signal_length;
  for (int l = 1; l <= level_; ++l) {
    n_.push_back(dwt_coeff_len(n_.back(), f, mode));
    biggest = std::max(biggest, n_.back());
  }
  offset_.push_back(0);
  for (std::size_t b = 0; b < band_count(); ++b) offset_.push_back(offset_.back() + band_length(b));
  rec_len_ = level_ == 0 ? signal_length : idwt_len(n_[1], f, mode);
  scratch_a_.assign(biggest + 2, 0.0);
  scratch_b_.assign(biggest + 2, 0.0);
}

std::size_t WaveletPlan::band_length(std::size_t band) const {
  if (band >= band_count()) throw std::invalid_argument("band " + std::to_string(band) + " out of range");
  const auto L = static_cast<std::size_t>(level_);
  return band == 0 ? n_[L] : n_[L + 1 - band];
}

std::size_t WaveletPlan::band_offset(std::size_t band) const {
  if (band >= band_count()) throw std::invalid_argument("band " + std::to_string(band) + " out of range");
  return offset_[band];
}

void WaveletPlan::check_packed(std::span<const double> packed) const {
  if (packed.size() < coeff_count()) {
    throw std::invalid_argument("packed coefficients: " + std::to_string(packed.size()) + " values, need " +
                                std::to_string(coeff_count()));
  }
}

void WaveletPlan::decompose(std::span<const double> x, std::span<double> packed) {
  if (x.size() != signal_length()) {
    throw std::invalid_argument("decompose: signal of " + std::to_string(x.size()) + " samples, plan is for " +
                                std::to_string(signal_length()));
  }
  check_packed(packed);
  if (level_ == 0) {
    std::copy(x.begin(), x.end(), packed.begin());
    return;
  }
  std::span<const double> in = x;
  double* bufs[2] = {scratch_a_.data(), scratch_b_.data()};
  for (int l = 1; l <= level_; ++l) {
    const std::size_t band_d = band_count() - static_cast<std::size_t>(l);  // cD_l
    double* d = packed.data() + offset_[band_d];
    double* a = l == level_ ? packed.data() : bufs[l % 2];
    detail::analysis_level(in, wavelet_, mode_, a, d);
    in = std::span<const double>(a, n_[static_cast<std::size_t>(l)]);
  }
}

void WaveletPlan::reconstruct(std::span<const double> packed, std::span<double> out) {
  check_packed(packed);
  if (out.size() < rec_len_) throw std::invalid_argument("reconstruct: output buffer too short");
  if (level_ == 0) {
    std::copy(packed.begin(), packed.begin() + static_cast<std::ptrdiff_t>(n_[0]), out.begin());
    return;
  }
  const double* a = packed.data();
  double* bufs[2] = {scratch_a_.data(), scratch_b_.data()};
  for (int l = level_; l >= 1; --l) {
    const auto lu = static_cast<std::size_t>(l);
    const std::size_t band_d = band_count() - lu;
    const double* d = packed.data() + offset_[band_d];
    // The approximation reconstructed from level l is trimmed to level l-1's length (as pywt.waverec does);
    // only the samples kept are computed. The last stage gives waverec's full length.
    const std::size_t n_out = l == 1 ? rec_len_ : n_[lu - 1];
    double* y = l == 1 ? out.data() : bufs[l % 2];
    detail::synthesis_level(a, d, n_[lu], wavelet_, mode_, false, y, n_out);
    a = y;
  }
}

void WaveletPlan::component(std::span<const double> packed, std::size_t band, std::span<double> out) {
  check_packed(packed);
  if (band >= band_count()) throw std::invalid_argument("component: band " + std::to_string(band) + " out of range");
  if (out.size() < signal_length()) throw std::invalid_argument("component: output buffer too short");
  const double* c = packed.data() + offset_[band];
  if (level_ == 0) {
    std::copy(c, c + n_[0], out.begin());
    return;
  }
  // Band 0 starts at level J through the low-pass; band b >= 1 is cD_j, j = J + 1 - b, through the high-pass
  // once, then the low-pass down to the signal.
  const auto L = static_cast<std::size_t>(level_);
  const std::size_t start = band == 0 ? L : L + 1 - band;
  bool is_detail = band != 0;
  double* bufs[2] = {scratch_a_.data(), scratch_b_.data()};
  for (std::size_t l = start; l >= 1; --l) {
    const std::size_t n_out = n_[l - 1];
    double* y = l == 1 ? out.data() : bufs[l % 2];
    detail::synthesis_level(c, nullptr, n_[l], wavelet_, mode_, is_detail, y, n_out);
    c = y;
    is_detail = false;
  }
}

void WaveletPlan::components(std::span<const double> packed, std::span<double> out) {
  const std::size_t n = signal_length();
  if (out.size() < band_count() * n) throw std::invalid_argument("components: output buffer too short");
  for (std::size_t b = 0; b < band_count(); ++b) component(packed, b, out.subspan(b * n, n));
}

}  // namespace guideway::dsp
