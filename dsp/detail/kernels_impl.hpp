#pragma once
// Kernel bodies (see kernels.hpp), included by kernels.cpp (baseline x86-64) and kernels_avx2.cpp (-mavx2) into
// the namespace KERNEL_NS; kernels.cpp picks one at run time. Explicit 4-wide vectors (GCC vector extensions):
// every lane performs the same IEEE multiplies and adds, in the same order, as the scalar tails, and
// -ffp-contract=off forbids fusing, so all variants give identical bits.

#include <cstddef>
#include <cstring>

#include "dsp/detail/kernels.hpp"

namespace guideway::dsp::detail::KERNEL_NS {

using v4 = double __attribute__((vector_size(32), aligned(8), may_alias));
using i4 = long long __attribute__((vector_size(32)));

// Through memcpy: an unaligned vector load or store either way (clang does not lower a typedef's alignment
// below the vector's 32 bytes, so a dereference would be a misaligned access to it; its UBSan says so).
inline v4 load(const double* p) {
  v4 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store(double* p, v4 v) { std::memcpy(p, &v, sizeof v); }
inline v4 splat(double x) { return v4{x, x, x, x}; }

constexpr std::size_t kTile = 64;  // analysis outputs per de-interleaved tile

// a[o] = sum_j lo[j] w[2o+F-1-j]. Even/odd input samples are de-interleaved per tile (E[i] = w[2i],
// O[i] = w[2i+1]); tap j = F-2-2r reads O[o+r], tap j = F-1-2r reads E[o+r]; r runs down so j runs up.
template <std::size_t F>
void analysis(const double* __restrict w, std::size_t n, const double* __restrict lo, const double* __restrict hi,
              double* __restrict a, double* __restrict d) {
  constexpr std::size_t H = F / 2;
  double E[kTile + H];
  double O[kTile + H];
  for (std::size_t o0 = 0; o0 < n; o0 += kTile) {
    const std::size_t t = n - o0 < kTile ? n - o0 : kTile;
    const double* base = w + 2 * o0;
    for (std::size_t i = 0; i < t + H - 1; ++i) {
      E[i] = base[2 * i];
      O[i] = base[2 * i + 1];
    }
    std::size_t q = 0;
    for (; q + 8 <= t; q += 8) {
      v4 sa0 = splat(0.0), sa1 = splat(0.0), sd0 = splat(0.0), sd1 = splat(0.0);
      for (std::size_t k = 0; k < H; ++k) {
        const std::size_t r = H - 1 - k;
        const v4 le = splat(lo[2 * k]), he = splat(hi[2 * k]);  // j = 2k = F-2-2r
        const v4 o0v = load(O + q + r), o1v = load(O + q + r + 4);
        sa0 += le * o0v;
        sa1 += le * o1v;
        sd0 += he * o0v;
        sd1 += he * o1v;
        const v4 lo1 = splat(lo[2 * k + 1]), ho1 = splat(hi[2 * k + 1]);  // j = 2k+1 = F-1-2r
        const v4 e0v = load(E + q + r), e1v = load(E + q + r + 4);
        sa0 += lo1 * e0v;
        sa1 += lo1 * e1v;
        sd0 += ho1 * e0v;
        sd1 += ho1 * e1v;
      }
      store(a + o0 + q, sa0);
      store(a + o0 + q + 4, sa1);
      store(d + o0 + q, sd0);
      store(d + o0 + q + 4, sd1);
    }
    for (; q < t; ++q) {
      double sa = 0.0, sd = 0.0;
      for (std::size_t k = 0; k < H; ++k) {
        const std::size_t r = H - 1 - k;
        sa += lo[2 * k] * O[q + r];
        sd += hi[2 * k] * O[q + r];
        sa += lo[2 * k + 1] * E[q + r];
        sd += hi[2 * k + 1] * E[q + r];
      }
      a[o0 + q] = sa;
      d[o0 + q] = sd;
    }
  }
}

// Interleave even-sample and odd-sample vectors into y[0..7].
inline void store_pairs(double* y, v4 even, v4 odd) {
#if defined(__clang__)  // clang spells GCC's vector shuffle with its lane numbers as arguments
  store(y, __builtin_shufflevector(even, odd, 0, 4, 1, 5));
  store(y + 4, __builtin_shufflevector(even, odd, 2, 6, 3, 7));
#else
  store(y, __builtin_shuffle(even, odd, i4{0, 4, 1, 5}));
  store(y + 4, __builtin_shuffle(even, odd, i4{2, 6, 3, 7}));
#endif
}

// y[2m+e] = sum_p g[2p+e] c[m+H-1-p].
template <std::size_t F>
void synthesis1(const double* __restrict c, std::size_t n, const double* __restrict g, double* __restrict y) {
  constexpr std::size_t H = F / 2;
  std::size_t m = 0;
  for (; m + 8 <= n; m += 8) {
    v4 se0 = splat(0.0), se1 = splat(0.0), so0 = splat(0.0), so1 = splat(0.0);
    for (std::size_t p = 0; p < H; ++p) {
      const v4 ge = splat(g[2 * p]), go = splat(g[2 * p + 1]);
      const v4 c0 = load(c + m + H - 1 - p), c1 = load(c + m + H + 3 - p);
      se0 += ge * c0;
      se1 += ge * c1;
      so0 += go * c0;
      so1 += go * c1;
    }
    store_pairs(y + 2 * m, se0, so0);
    store_pairs(y + 2 * m + 8, se1, so1);
  }
  for (; m < n; ++m) {
    double se = 0.0, so = 0.0;
    for (std::size_t p = 0; p < H; ++p) {
      const double v = c[m + H - 1 - p];
      se += g[2 * p] * v;
      so += g[2 * p + 1] * v;
    }
    y[2 * m] = se;
    y[2 * m + 1] = so;
  }
}

// y = (approximation part) + (detail part), each summed as in synthesis1 (PyWavelets' idwt order).
template <std::size_t F>
void synthesis2(const double* __restrict a, const double* __restrict d, std::size_t n, const double* __restrict ga,
                const double* __restrict gd, double* __restrict y) {
  constexpr std::size_t H = F / 2;
  std::size_t m = 0;
  for (; m + 8 <= n; m += 8) {
    v4 se0 = splat(0.0), se1 = splat(0.0), so0 = splat(0.0), so1 = splat(0.0);
    v4 te0 = splat(0.0), te1 = splat(0.0), to0 = splat(0.0), to1 = splat(0.0);
    for (std::size_t p = 0; p < H; ++p) {
      const v4 ae = splat(ga[2 * p]), ao = splat(ga[2 * p + 1]);
      const v4 de = splat(gd[2 * p]), dd = splat(gd[2 * p + 1]);
      const v4 a0 = load(a + m + H - 1 - p), a1 = load(a + m + H + 3 - p);
      const v4 d0 = load(d + m + H - 1 - p), d1 = load(d + m + H + 3 - p);
      se0 += ae * a0;
      se1 += ae * a1;
      so0 += ao * a0;
      so1 += ao * a1;
      te0 += de * d0;
      te1 += de * d1;
      to0 += dd * d0;
      to1 += dd * d1;
    }
    store_pairs(y + 2 * m, se0 + te0, so0 + to0);
    store_pairs(y + 2 * m + 8, se1 + te1, so1 + to1);
  }
  for (; m < n; ++m) {
    double se = 0.0, so = 0.0, te = 0.0, to = 0.0;
    for (std::size_t p = 0; p < H; ++p) {
      const double va = a[m + H - 1 - p];
      const double vd = d[m + H - 1 - p];
      se += ga[2 * p] * va;
      so += ga[2 * p + 1] * va;
      te += gd[2 * p] * vd;
      to += gd[2 * p + 1] * vd;
    }
    y[2 * m] = se + te;
    y[2 * m + 1] = so + to;
  }
}

template <std::size_t... I>
constexpr std::array<Kernels, sizeof...(I)> make_table(std::index_sequence<I...>) {
  return {Kernels{&analysis<2 * (I + 1)>, &synthesis1<2 * (I + 1)>, &synthesis2<2 * (I + 1)>}...};
}

}  // namespace guideway::dsp::detail::KERNEL_NS
