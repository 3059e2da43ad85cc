// Streaming cascade: analysis stages (one per level) feed the sink, the synthesis chains of the components (one
// chain per band: high- or low-pass once, then low-pass down to the signal) and the denoising synthesis (two
// bands per level). Every stage keeps its pending inputs in a preallocated FIFO and runs the same kernels as the
// batch code on whatever it can compute; outputs are released with the fixed latency L.
#include "dsp/streaming_wavelet.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dsp/detail/kernels.hpp"

namespace guideway::dsp {

namespace {

// Contiguous FIFO in a fixed buffer: live values [head, tail); compacts to the front when the tail would pass the
// end. Capacity is sized for twice the worst live size plus an input burst, so compaction is amortised O(1).
class Fifo {
 public:
  void init(std::size_t capacity) {
    buf_.assign(capacity, 0.0);
    head_ = tail_ = 0;
  }
  void clear() { head_ = tail_ = 0; }
  [[nodiscard]] std::size_t size() const { return tail_ - head_; }
  [[nodiscard]] const double* data() const { return buf_.data() + head_; }
  double* reserve(std::size_t n) {
    if (tail_ + n > buf_.size()) {
      const std::size_t live = size();
      std::copy(buf_.begin() + static_cast<std::ptrdiff_t>(head_), buf_.begin() + static_cast<std::ptrdiff_t>(tail_),
                buf_.begin());
      head_ = 0;
      tail_ = live;
      if (tail_ + n > buf_.size()) throw std::logic_error("streaming wavelet: internal buffer overflow");
    }
    return buf_.data() + tail_;
  }
  void commit(std::size_t n) { tail_ += n; }
  void consume(std::size_t n) {
    head_ += n;
    if (head_ == tail_) head_ = tail_ = 0;
  }
  void append(std::span<const double> v) {
    std::copy(v.begin(), v.end(), reserve(v.size()));
    commit(v.size());
  }
  void append_zeros(std::size_t n) {
    std::fill_n(reserve(n), n, 0.0);
    commit(n);
  }

 private:
  std::vector<double> buf_;
  std::size_t head_ = 0;
  std::size_t tail_ = 0;
};

// Robust noise level over the last `window` detail coefficients with a log of thresholds by coefficient count.
class NoiseEstimator {
 public:
  void init(std::size_t window, double log_factor) {
    window_ = window;
    log_factor_ = log_factor;
    ring_.assign(window, 0.0);
    scratch_.assign(window, 0.0);
    reset();
  }
  void reset() {
    count_ = 0;
    next_ = std::min<std::uint64_t>(16, window_);
    lambda_ = 0.0;
    log_size_ = 0;
    log_pos_ = 0;
  }
  // Adds |v|; returns the threshold in force for this coefficient (after any refresh it triggers).
  double add(double v) {
    ring_[static_cast<std::size_t>(count_ % window_)] = std::fabs(v);
    ++count_;
    if (count_ == next_) refresh();
    return lambda_;
  }
  // Threshold that was in force after `count` coefficients (0 before the first estimate).
  [[nodiscard]] double lambda_at(std::uint64_t count) const {
    for (std::size_t i = 0; i < log_size_; ++i) {
      const auto& e = log_[(log_pos_ + kLog - 1 - i) % kLog];
      if (e.count <= count) return e.lambda;
    }
    return log_size_ == kLog ? log_[log_pos_ % kLog].lambda : 0.0;
  }
  [[nodiscard]] double lambda() const { return lambda_; }

 private:
  void refresh() {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(count_, window_));
    std::copy_n(ring_.begin(), n, scratch_.begin());
    const std::size_t mid = n / 2;
    auto first = scratch_.begin();
    std::nth_element(first, first + static_cast<std::ptrdiff_t>(mid), first + static_cast<std::ptrdiff_t>(n));
    double med = scratch_[mid];
    if (n % 2 == 0) med = 0.5 * (med + *std::max_element(first, first + static_cast<std::ptrdiff_t>(mid)));
    lambda_ = med / 0.6745 * log_factor_;
    log_[log_pos_ % kLog] = {count_, lambda_};
    log_pos_ = (log_pos_ + 1) % kLog;
    log_size_ = std::min(log_size_ + 1, kLog);
    next_ = count_ < window_ ? std::min<std::uint64_t>(2 * count_, window_) : count_ + window_ / 4;
  }

  struct Entry {
    std::uint64_t count = 0;
    double lambda = 0.0;
  };
  static constexpr std::size_t kLog = 256;
  std::size_t window_ = 0;
  double log_factor_ = 0.0;
  std::vector<double> ring_;
  std::vector<double> scratch_;
  std::uint64_t count_ = 0;
  std::uint64_t next_ = 0;
  double lambda_ = 0.0;
  std::array<Entry, kLog> log_{};
  std::size_t log_size_ = 0;
  std::size_t log_pos_ = 0;
};

struct Chain {
  std::vector<Fifo> stage_in;       // input of each synthesis stage, deepest level first
  std::vector<const double*> filt;  // rec_hi (detail band, first stage) or rec_lo
  Fifo out;                         // signal-domain component, not yet delivered
};

}  // namespace

struct StreamingWavelet::Impl {
  static constexpr std::size_t kMaxBufferDoubles = std::size_t{32} << 20;  // 256 MiB
  Wavelet w;
  StreamingOptions opt;
  const detail::Kernels* kern = nullptr;
  std::size_t F = 0;
  std::size_t H = 0;
  int J = 0;
  std::size_t L = 0;
  std::size_t B = 0;
  std::uint64_t pushed = 0;
  bool finished = false;

  // analysis, index l-1 for level l
  std::vector<Fifo> ain;
  std::vector<std::uint64_t> received;
  std::vector<std::uint64_t> produced;
  std::vector<double> dbuf;
  std::vector<double> abuf;
  std::vector<double> tbuf;  // thresholded details

  std::vector<Chain> chains;  // band order
  std::uint64_t comp_emitted = 0;
  std::vector<const double*> comp_ptrs;

  std::vector<Fifo> den_a;  // index l-1: approximation input of synthesis level l
  std::vector<Fifo> den_d;  // index l-1: (thresholded) detail input of synthesis level l
  Fifo den_out;
  std::uint64_t den_emitted = 0;
  std::vector<NoiseEstimator> est;  // 1 (finest level drives all) or J (level dependent)
  double fixed_lambda = -1.0;       // >= 0 when fixed

  Impl(const Wavelet& wavelet, const StreamingOptions& o) : w(wavelet), opt(o) {
    kern = &detail::kernels_for(w.filter_length());
    if (kern->analysis == nullptr) throw std::invalid_argument("streaming wavelet: unsupported filter length");
    if (opt.levels < 1 || opt.levels > 16) {
      throw std::invalid_argument("streaming wavelet: levels must be in 1..16, got " + std::to_string(opt.levels));
    }
    if (opt.block < 16) throw std::invalid_argument("streaming wavelet: block must be >= 16 samples");
    F = w.filter_length();
    H = F / 2;
    J = opt.levels;
    L = latency_for(F, J);
    B = opt.block;
    const std::size_t two_j = std::size_t{1} << J;
    // Worst live sizes: an input burst (one block, amplified back by synthesis) plus the lag of a stage's
    // inputs behind each other (< (F-1) 2^J) plus the history.
    const std::size_t burst = B + two_j + 2 * F + 8;
    const std::size_t lag = (F - 1) * two_j + F;
    const std::size_t cap = 2 * (burst + lag) + 64;
    const std::size_t out_cap = 2 * (L + burst) + 64;
    const auto Ju = static_cast<std::size_t>(J);
    const std::size_t doubles = (opt.components ? (Ju + Ju * (Ju + 1) / 2) * cap + (Ju + 1) * out_cap : 0) +
                                (opt.denoise ? 2 * Ju * cap + out_cap : 0);
    if (doubles > kMaxBufferDoubles) {
      throw std::invalid_argument("streaming wavelet: " + std::to_string(J) + " levels of a " + std::to_string(F) +
                                  "-tap filter need " + std::to_string(doubles * sizeof(double) >> 20) +
                                  " MiB of buffers (limit 256 MiB): use fewer levels");
    }
    ain.resize(static_cast<std::size_t>(J));
    for (auto& f : ain) f.init(2 * (B + 2 * F) + 64);
    received.assign(static_cast<std::size_t>(J), 0);
    produced.assign(static_cast<std::size_t>(J), 0);
    dbuf.assign(B / 2 + F + 8, 0.0);
    abuf.assign(B / 2 + F + 8, 0.0);
    tbuf.assign(B / 2 + F + 8, 0.0);
    if (opt.components) {
      chains.resize(static_cast<std::size_t>(J) + 1);
      for (std::size_t b = 0; b <= static_cast<std::size_t>(J); ++b) {
        const std::size_t start = b == 0 ? static_cast<std::size_t>(J) : static_cast<std::size_t>(J) + 1 - b;
        auto& c = chains[b];
        c.stage_in.resize(start);
        for (auto& f : c.stage_in) f.init(cap);
        for (std::size_t s = 0; s < start; ++s)
          c.filt.push_back(s == 0 && b != 0 ? w.rec_hi().data() : w.rec_lo().data());
        c.out.init(out_cap);
      }
      comp_ptrs.assign(chains.size(), nullptr);
    }
    if (opt.denoise) {
      const auto& d = opt.denoise_options;
      den_a.resize(static_cast<std::size_t>(J));
      den_d.resize(static_cast<std::size_t>(J));
      for (auto& f : den_a) f.init(cap);
      for (auto& f : den_d) f.init(cap);
      den_out.init(out_cap);
      if (d.threshold) {
        if (!(*d.threshold >= 0.0)) throw std::invalid_argument("streaming denoise: threshold must be >= 0");
        fixed_lambda = *d.threshold;
      } else {
        if (d.window < 64) throw std::invalid_argument("streaming denoise: window must be >= 64 coefficients");
        const std::size_t n_ref = d.threshold_length != 0 ? d.threshold_length : 2 * d.window;
        const double log_factor = n_ref > 1 ? std::sqrt(2.0 * std::log(static_cast<double>(n_ref))) : 0.0;
        if (d.sigma) {
          if (!(*d.sigma >= 0.0)) throw std::invalid_argument("streaming denoise: sigma must be >= 0");
          fixed_lambda = *d.sigma * log_factor;
        } else {
          est.resize(d.level_dependent ? static_cast<std::size_t>(J) : 1);
          for (auto& e : est) e.init(d.window, log_factor);
        }
      }
    }
    reset();
  }

  static std::size_t latency_for(std::size_t f, int levels) { return (f - 1) * ((std::size_t{1} << levels) - 1); }

  void reset() {
    pushed = 0;
    finished = false;
    for (std::size_t l = 0; l < ain.size(); ++l) {
      ain[l].clear();
      ain[l].append_zeros(F - 2);  // zero-mode history of samples -(F-2)..-1
      received[l] = 0;
      produced[l] = 0;
    }
    for (auto& c : chains) {
      for (auto& f : c.stage_in) f.clear();
      c.out.clear();
    }
    comp_emitted = 0;
    for (auto& f : den_a) f.clear();
    for (auto& f : den_d) f.clear();
    den_out.clear();
    den_emitted = 0;
    for (auto& e : est) e.reset();
  }

  [[nodiscard]] std::size_t band_of_detail(std::size_t level) const { return static_cast<std::size_t>(J) + 1 - level; }

  // Threshold the new details of `level` (coefficients [first, first + n)) into tbuf.
  void threshold_details(std::size_t level, std::uint64_t first, const double* d, std::size_t n) {
    const ThresholdRule rule = opt.denoise_options.rule;
    if (fixed_lambda >= 0.0) {
      for (std::size_t i = 0; i < n; ++i) tbuf[i] = apply_threshold(d[i], fixed_lambda, rule);
    } else if (est.size() > 1 || level == 1) {
      auto& e = est[est.size() > 1 ? level - 1 : 0];
      for (std::size_t i = 0; i < n; ++i) tbuf[i] = apply_threshold(d[i], e.add(d[i]), rule);
    } else {
      // Deeper level, one estimate: the threshold in force at this coefficient's time, i.e. after the
      // 2^(level-1) (o + 1) finest coefficients that precede it, whatever the chunking.
      for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t c1 = (first + i + 1) << (level - 1);
        tbuf[i] = apply_threshold(d[i], est[0].lambda_at(c1), rule);
      }
    }
  }

  void process_level(std::size_t level, WaveletSink& sink) {
    const std::size_t li = level - 1;
    auto& in = ain[li];
    const std::uint64_t can = received[li] / 2;
    const auto k = static_cast<std::size_t>(can - produced[li]);
    if (k == 0) return;
    const bool last = level == static_cast<std::size_t>(J);
    double* a = last ? abuf.data() : ain[li + 1].reserve(k);
    kern->analysis(in.data(), k, w.dec_lo().data(), w.dec_hi().data(), a, dbuf.data());
    in.consume(2 * k);
    const std::uint64_t first = produced[li];
    produced[li] += k;
    const std::span<const double> d(dbuf.data(), k);
    const std::size_t band = band_of_detail(level);
    if (opt.coefficients) sink.on_coefficients(band, first, d);
    if (opt.components) chains[band].stage_in[0].append(d);
    if (opt.denoise) {
      threshold_details(level, first, dbuf.data(), k);
      den_d[li].append(std::span<const double>(tbuf.data(), k));
    }
    if (!last) {
      ain[li + 1].commit(k);
      received[li + 1] += k;
    } else {
      const std::span<const double> av(abuf.data(), k);
      if (opt.coefficients) sink.on_coefficients(0, first, av);
      if (opt.components) chains[0].stage_in[0].append(av);
      if (opt.denoise) den_a[li].append(av);
    }
  }

  void run_chains() {
    for (auto& c : chains) {
      for (std::size_t s = 0; s < c.stage_in.size(); ++s) {
        auto& in = c.stage_in[s];
        if (in.size() < H) continue;
        const std::size_t k = in.size() - (H - 1);
        Fifo& dst = s + 1 < c.stage_in.size() ? c.stage_in[s + 1] : c.out;
        kern->synthesis1(in.data(), k, c.filt[s], dst.reserve(2 * k));
        dst.commit(2 * k);
        in.consume(k);
      }
    }
  }

  void run_denoise() {
    if (!opt.denoise) return;
    for (std::size_t level = static_cast<std::size_t>(J); level >= 1; --level) {
      auto& a = den_a[level - 1];
      auto& d = den_d[level - 1];
      const std::size_t avail = std::min(a.size(), d.size());
      if (avail < H) continue;
      const std::size_t k = avail - (H - 1);
      Fifo& dst = level > 1 ? den_a[level - 2] : den_out;
      kern->synthesis2(a.data(), d.data(), k, w.rec_lo().data(), w.rec_hi().data(), dst.reserve(2 * k));
      dst.commit(2 * k);
      a.consume(k);
      d.consume(k);
    }
  }

  void emit(WaveletSink& sink) {
    const std::uint64_t limit = finished ? pushed : (pushed > L ? pushed - L : 0);
    if (opt.components) {
      std::uint64_t avail = limit;
      for (const auto& c : chains) avail = std::min<std::uint64_t>(avail, comp_emitted + c.out.size());
      if (avail > comp_emitted) {
        const auto e = static_cast<std::size_t>(avail - comp_emitted);
        for (std::size_t b = 0; b < chains.size(); ++b) comp_ptrs[b] = chains[b].out.data();
        sink.on_components(comp_emitted, e, comp_ptrs);
        for (auto& c : chains) c.out.consume(e);
        comp_emitted += e;
      }
    }
    if (opt.denoise) {
      const std::uint64_t avail = std::min<std::uint64_t>(limit, den_emitted + den_out.size());
      if (avail > den_emitted) {
        const auto e = static_cast<std::size_t>(avail - den_emitted);
        sink.on_denoised(den_emitted, std::span<const double>(den_out.data(), e));
        den_out.consume(e);
        den_emitted += e;
      }
    }
  }

  void run_block(std::span<const double> x, WaveletSink& sink) {
    ain[0].append(x);
    received[0] += x.size();
    pushed += x.size();
    for (std::size_t level = 1; level <= static_cast<std::size_t>(J); ++level) process_level(level, sink);
    run_chains();
    run_denoise();
    emit(sink);
  }

  void push(std::span<const double> x, WaveletSink& sink) {
    if (finished) throw std::logic_error("streaming wavelet: push after flush (call reset() first)");
    while (!x.empty()) {
      const std::size_t n = std::min(x.size(), B);
      run_block(x.first(n), sink);
      x = x.subspan(n);
    }
  }

  void flush(WaveletSink& sink) {
    if (finished) return;
    finished = true;
    if (pushed == 0) return;
    // Zero mode: level l has floor((n_(l-1) + F - 1) / 2) coefficients; feed each level the zeros that complete
    // them (its input after the signal is zero), level by level.
    std::uint64_t n_prev = pushed;
    for (std::size_t level = 1; level <= static_cast<std::size_t>(J); ++level) {
      const std::size_t li = level - 1;
      process_level(level, sink);
      const std::uint64_t n_l = (n_prev + F - 1) / 2;
      const auto zeros = static_cast<std::size_t>(2 * n_l - received[li]);
      ain[li].append_zeros(zeros);
      received[li] += zeros;
      process_level(level, sink);
      n_prev = n_l;
    }
    run_chains();
    run_denoise();
    emit(sink);
  }
};

StreamingWavelet::StreamingWavelet(const Wavelet& wavelet, const StreamingOptions& options)
    : impl_(std::make_unique<Impl>(wavelet, options)) {}
StreamingWavelet::~StreamingWavelet() = default;
StreamingWavelet::StreamingWavelet(StreamingWavelet&&) noexcept = default;
StreamingWavelet& StreamingWavelet::operator=(StreamingWavelet&&) noexcept = default;

const Wavelet& StreamingWavelet::wavelet() const { return impl_->w; }
int StreamingWavelet::levels() const { return impl_->J; }
std::size_t StreamingWavelet::latency() const { return impl_->L; }
std::size_t StreamingWavelet::latency_for(std::size_t filter_length, int levels) {
  return Impl::latency_for(filter_length, levels);
}
std::uint64_t StreamingWavelet::samples_pushed() const { return impl_->pushed; }
bool StreamingWavelet::finished() const { return impl_->finished; }
void StreamingWavelet::push(std::span<const double> x, WaveletSink& sink) { impl_->push(x, sink); }
void StreamingWavelet::flush(WaveletSink& sink) { impl_->flush(sink); }
void StreamingWavelet::reset() { impl_->reset(); }

}  // namespace guideway::dsp
