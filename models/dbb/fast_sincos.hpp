#pragma once
// sin and cos of one argument together, inline and without libm's call and rounding-mode overhead,
// for searches that evaluate ~1e5 of them only to compare sums (the DBB cyclic-lead search).
// Accuracy: within 2 ulp of libm, absolute error <= 4e-16 (checked against std::sin/std::cos by
// tests/models/dbb/dbb_fast_sincos_test.cpp). Beyond |x| = 1e6, where the reduction would lose bits, and for
// non-finite x it calls libm. Thread safe.

#include <cmath>
#include <cstddef>

namespace guideway::models::dbb {

namespace detail {
// sin and cos of |x| <= 1e6 (below 2^31 pi/2: the quadrant fits an int), without a branch: a loop of it
// vectorizes (fast_sincos_batch).
inline void sincos_in_range(double x, double& s, double& c) {
  // Cody-Waite reduction x = k pi/2 + r, |r| <= pi/4, with pi/2 split in three (fdlibm's pio2_1,
  // pio2_2, pio2_2t): k p1 and k p2 are exact for |k| < 2^20.
  constexpr double two_over_pi = 6.36619772367581382433e-01;
  constexpr double p1 = 1.57079632673412561417e+00;
  constexpr double p2 = 6.07710050630396597660e-11;
  constexpr double p3 = 2.02226624879595063154e-21;
  constexpr double round_magic = 6755399441055744.0;  // 1.5 * 2^52: adding it rounds to an integer
  const double k = (x * two_over_pi + round_magic) - round_magic;
  const double r = ((x - k * p1) - k * p2) - k * p3;
  const double z = r * r;
  // fdlibm's __kernel_sin and __kernel_cos polynomials on [-pi/4, pi/4].
  const double sr = r + r * z *
                            (-1.66666666666666324348e-01 +
                             z * (8.33333333332248946124e-03 +
                                  z * (-1.98412698298579493134e-04 +
                                       z * (2.75573137070700676789e-06 +
                                            z * (-2.50507602534068634195e-08 + z * 1.58969099521155010221e-10)))));
  const double poly = z * (4.16666666666666019037e-02 +
                           z * (-1.38888888888741095749e-03 +
                                z * (2.48015872894767294178e-05 +
                                     z * (-2.75573143513906633035e-07 +
                                          z * (2.08757232129817482790e-09 + z * -1.13596475577881948265e-11)))));
  const double hz = 0.5 * z;
  const double w = 1.0 - hz;
  const double cr = w + (((1.0 - w) - hz) + z * poly);
  // Quadrant q = k mod 4: (s, c) = (sr, cr), (cr, -sr), (-sr, -cr), (-cr, sr); selects, not a switch.
  const int q = static_cast<int>(k);
  const double a = (q & 1) != 0 ? cr : sr, b = (q & 1) != 0 ? sr : cr;
  s = (q & 2) != 0 ? -a : a;
  c = ((q + 1) & 2) != 0 ? -b : b;
}
}  // namespace detail

inline void fast_sincos(double x, double& s, double& c) {
  if (!(std::abs(x) <= 1e6)) {
    s = std::sin(x);
    c = std::cos(x);
    return;
  }
  detail::sincos_in_range(x, s, c);
}

// fast_sincos of x[0..n) into s and c (none of them overlapping), the same bits: when every argument is in range,
// a vector at a time (about twice as fast in the DBB cyclic-lead and vibration searches), else one by one.
inline void fast_sincos_batch(const double* __restrict x, double* __restrict s, double* __restrict c, std::size_t n) {
  std::size_t outside = 0;
  for (std::size_t i = 0; i < n; ++i) outside += std::abs(x[i]) <= 1e6 ? 0 : 1;
  if (outside > 0) {
    for (std::size_t i = 0; i < n; ++i) fast_sincos(x[i], s[i], c[i]);
    return;
  }
  for (std::size_t i = 0; i < n; ++i) {
    double si = 0, ci = 0;
    detail::sincos_in_range(x[i], si, ci);
    s[i] = si;
    c[i] = ci;
  }
}

}  // namespace guideway::models::dbb
