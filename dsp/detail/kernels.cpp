// Filter-length-specialised inner loops (see kernels.hpp). Compiled with -O3 -ffp-contract=off: the compiler
// may vectorise across outputs, which keeps each output's summation order, and never fuses multiply-adds,
// so every code path (vector body, scalar tail, batch, streaming) produces the same bits.
#include "dsp/detail/kernels.hpp"

#include <array>
#include <utility>

namespace guideway::dsp::detail {

namespace {

constexpr std::size_t kBlock = 8;  // outputs per register block

template <std::size_t F>
void analysis(const double* __restrict w, std::size_t n, const double* __restrict lo, const double* __restrict hi,
              double* __restrict a, double* __restrict d) {
  double l[F];
  double h[F];
  for (std::size_t j = 0; j < F; ++j) {
    l[j] = lo[j];
    h[j] = hi[j];
  }
  std::size_t o = 0;
  for (; o + kBlock <= n; o += kBlock) {
    double sa[kBlock] = {};
    double sd[kBlock] = {};
    const double* p = w + 2 * o;
    for (std::size_t j = 0; j < F; ++j) {
      for (std::size_t b = 0; b < kBlock; ++b) {
        const double v = p[2 * b + (F - 1) - j];
        sa[b] += l[j] * v;
        sd[b] += h[j] * v;
      }
    }
    for (std::size_t b = 0; b < kBlock; ++b) {
      a[o + b] = sa[b];
      d[o + b] = sd[b];
    }
  }
  for (; o < n; ++o) {
    const double* p = w + 2 * o;
    double sa = 0.0;
    double sd = 0.0;
    for (std::size_t j = 0; j < F; ++j) {
      const double v = p[(F - 1) - j];
      sa += l[j] * v;
      sd += h[j] * v;
    }
    a[o] = sa;
    d[o] = sd;
  }
}

template <std::size_t F>
void synthesis1(const double* __restrict c, std::size_t n, const double* __restrict g, double* __restrict y) {
  constexpr std::size_t H = F / 2;
  double ge[H];
  double go[H];
  for (std::size_t p = 0; p < H; ++p) {
    ge[p] = g[2 * p];
    go[p] = g[2 * p + 1];
  }
  std::size_t m = 0;
  for (; m + kBlock <= n; m += kBlock) {
    double se[kBlock] = {};
    double so[kBlock] = {};
    for (std::size_t p = 0; p < H; ++p) {
      for (std::size_t b = 0; b < kBlock; ++b) {
        const double v = c[m + b + H - 1 - p];
        se[b] += ge[p] * v;
        so[b] += go[p] * v;
      }
    }
    for (std::size_t b = 0; b < kBlock; ++b) {
      y[2 * (m + b)] = se[b];
      y[2 * (m + b) + 1] = so[b];
    }
  }
  for (; m < n; ++m) {
    double se = 0.0;
    double so = 0.0;
    for (std::size_t p = 0; p < H; ++p) {
      const double v = c[m + H - 1 - p];
      se += ge[p] * v;
      so += go[p] * v;
    }
    y[2 * m] = se;
    y[2 * m + 1] = so;
  }
}

template <std::size_t F>
void synthesis2(const double* __restrict a, const double* __restrict d, std::size_t n, const double* __restrict ga,
                const double* __restrict gd, double* __restrict y) {
  constexpr std::size_t H = F / 2;
  double ae[H];
  double ao[H];
  double de[H];
  double dd[H];
  for (std::size_t p = 0; p < H; ++p) {
    ae[p] = ga[2 * p];
    ao[p] = ga[2 * p + 1];
    de[p] = gd[2 * p];
    dd[p] = gd[2 * p + 1];
  }
  std::size_t m = 0;
  for (; m + kBlock <= n; m += kBlock) {
    double se[kBlock] = {};
    double so[kBlock] = {};
    double te[kBlock] = {};
    double to[kBlock] = {};
    for (std::size_t p = 0; p < H; ++p) {
      for (std::size_t b = 0; b < kBlock; ++b) {
        const double va = a[m + b + H - 1 - p];
        const double vd = d[m + b + H - 1 - p];
        se[b] += ae[p] * va;
        so[b] += ao[p] * va;
        te[b] += de[p] * vd;
        to[b] += dd[p] * vd;
      }
    }
    for (std::size_t b = 0; b < kBlock; ++b) {
      y[2 * (m + b)] = se[b] + te[b];
      y[2 * (m + b) + 1] = so[b] + to[b];
    }
  }
  for (; m < n; ++m) {
    double se = 0.0;
    double so = 0.0;
    double te = 0.0;
    double to = 0.0;
    for (std::size_t p = 0; p < H; ++p) {
      const double va = a[m + H - 1 - p];
      const double vd = d[m + H - 1 - p];
      se += ae[p] * va;
      so += ao[p] * va;
      te += de[p] * vd;
      to += dd[p] * vd;
    }
    y[2 * m] = se + te;
    y[2 * m + 1] = so + to;
  }
}

template <std::size_t... I>
constexpr std::array<Kernels, sizeof...(I)> make_table(std::index_sequence<I...>) {
  return {Kernels{&analysis<2 * (I + 1)>, &synthesis1<2 * (I + 1)>, &synthesis2<2 * (I + 1)>}...};
}

constexpr std::size_t kMaxHalf = 20;  // filter lengths 2, 4, ..., 40
const std::array<Kernels, kMaxHalf> kTable = make_table(std::make_index_sequence<kMaxHalf>{});
const Kernels kNone{nullptr, nullptr, nullptr};

}  // namespace

const Kernels& kernels_for(std::size_t filter_length) {
  if (filter_length < 2 || filter_length % 2 != 0 || filter_length / 2 > kMaxHalf) return kNone;
  return kTable[filter_length / 2 - 1];
}

}  // namespace guideway::dsp::detail
