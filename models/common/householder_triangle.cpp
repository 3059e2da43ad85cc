#include "models/common/householder_triangle.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace guideway::models {

namespace {

// Bytes of one chunk of weighted rows: reduced against the triangle while it sits in the L1 cache.
constexpr Eigen::Index chunk_bytes = 16 * 1024;

// Two doubles: the kernels below spell out their vector operations (GCC/Clang vector extension), so
// that each sum is formed in one fixed order, whatever the target.
using v2 = double __attribute__((vector_size(16)));

inline v2 load(const double* p) {
  v2 v;
  __builtin_memcpy(&v, p, sizeof v);
  return v;
}
inline void store(double* p, v2 v) { __builtin_memcpy(p, &v, sizeof v); }

// x . y for `cols` vectors y (1..4) at once, each as four interleaved partial sums (i mod 4)
// combined as (s0 + s1) + (s2 + s3); rows must be a multiple of 4. v is loaded once for all y.
template <int cols>
inline void dots(const double* x, const double* const* y, Eigen::Index rows, double* out) {
  v2 lo[cols], hi[cols];
  for (int c = 0; c < cols; ++c) lo[c] = hi[c] = v2{0.0, 0.0};
  for (Eigen::Index i = 0; i < rows; i += 4) {
    const v2 xl = load(x + i), xh = load(x + i + 2);
    for (int c = 0; c < cols; ++c) {
      lo[c] += xl * load(y[c] + i);
      hi[c] += xh * load(y[c] + i + 2);
    }
  }
  for (int c = 0; c < cols; ++c) out[c] = (lo[c][0] + lo[c][1]) + (hi[c][0] + hi[c][1]);
}

// y_c -= s_c x for `cols` vectors y at once; rows must be a multiple of 4.
template <int cols>
inline void axpys(const double* x, double* const* y, const double* s, Eigen::Index rows) {
  v2 f[cols];
  for (int c = 0; c < cols; ++c) f[c] = v2{s[c], s[c]};
  for (Eigen::Index i = 0; i < rows; i += 4) {
    const v2 xl = load(x + i), xh = load(x + i + 2);
    for (int c = 0; c < cols; ++c) {
      store(y[c] + i, load(y[c] + i) - f[c] * xl);
      store(y[c] + i + 2, load(y[c] + i + 2) - f[c] * xh);
    }
  }
}

// Applies the reflector I - tau [1; v] [1; v]^T to row k of R and to C, columns k+1..w-1, up to four
// columns per pass over v.
template <int cols>
void apply(double* r, Eigen::Index w, double* c, Eigen::Index rows, Eigen::Index k, Eigen::Index j, double tau) {
  const double* v = c + k * rows;
  double* y[cols];
  double s[cols];
  for (int q = 0; q < cols; ++q) y[q] = c + (j + q) * rows;
  dots<cols>(v, y, rows, s);
  for (int q = 0; q < cols; ++q) {
    double& rk = r[k + (j + q) * w];
    s[q] = tau * (rk + s[q]);
    rk -= s[q];
  }
  axpys<cols>(v, y, s, rows);
}

// Reduces [R; C] to [R'; 0] by Householder reflections, column by column: R is w x w upper
// triangular, C holds `rows` rows of w columns (both column-major, C with leading dimension rows, a
// multiple of 4; padding rows are zero). The reflector of column k acts on row k of R and all of C
// (the rows of R below k are zero in columns <= k), as LAPACK's dgeqrf on the stacked matrix would.
// C is overwritten.
void reduce(double* r, Eigen::Index w, double* c, Eigen::Index rows) {
  for (Eigen::Index k = 0; k < w; ++k) {
    double* v = c + k * rows;
    double sigma = 0;
    dots<1>(v, &v, rows, &sigma);
    // Nothing below the diagonal: the reflector is the identity (as Eigen's makeHouseholder).
    if (sigma <= std::numeric_limits<double>::min()) continue;
    const double alpha = r[k + k * w];
    const double norm = std::sqrt(alpha * alpha + sigma);
    const double beta = alpha >= 0 ? -norm : norm;
    const double inv = 1.0 / (alpha - beta);
    for (Eigen::Index i = 0; i < rows; ++i) v[i] *= inv;  // v = [1; C(:, k) / (alpha - beta)]
    const double tau = (beta - alpha) / beta;
    r[k + k * w] = beta;
    Eigen::Index j = k + 1;
    for (; j + 4 <= w; j += 4) apply<4>(r, w, c, rows, k, j, tau);
    switch (w - j) {
      case 3: apply<3>(r, w, c, rows, k, j, tau); break;
      case 2: apply<2>(r, w, c, rows, k, j, tau); break;
      case 1: apply<1>(r, w, c, rows, k, j, tau); break;
      default: break;
    }
  }
}

}  // namespace

Eigen::MatrixXd weighted_triangle(const Eigen::MatrixXd& a, const Eigen::VectorXd& y, const Eigen::VectorXd& sw) {
  const Eigen::Index n = a.rows();
  const Eigen::Index m = a.cols();
  const Eigen::Index w = m + 1;
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(w, w);
  const Eigen::Index chunk = std::max<Eigen::Index>(8, chunk_bytes / (Eigen::Index{sizeof(double)} * w)) / 4 * 4;
  Eigen::MatrixXd buf(std::min(chunk, (n + 3) / 4 * 4), w);
  for (Eigen::Index i0 = 0; i0 < n; i0 += chunk) {
    const Eigen::Index used = std::min(chunk, n - i0);
    const Eigen::Index rows = (used + 3) / 4 * 4;  // zero rows pad the last chunk to a multiple of 4
    double* c = buf.data();
    const double* s = sw.data() + i0;
    for (Eigen::Index j = 0; j < m; ++j) {
      const double* src = a.data() + j * n + i0;
      double* dst = c + j * rows;
      for (Eigen::Index i = 0; i < used; ++i) dst[i] = src[i] * s[i];
      for (Eigen::Index i = used; i < rows; ++i) dst[i] = 0.0;
    }
    const double* yi = y.data() + i0;
    double* dst = c + m * rows;
    for (Eigen::Index i = 0; i < used; ++i) dst[i] = yi[i] * s[i];
    for (Eigen::Index i = used; i < rows; ++i) dst[i] = 0.0;
    reduce(r.data(), w, c, rows);
  }
  return r;
}

}  // namespace guideway::models
