// Minimum-zone flatness of points (minimum_zone.hpp): the narrowest pair of parallel planes, solved exactly as a linear
// programme.
#include "models/flatness/minimum_zone.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

namespace guideway::models::flatness {

namespace {

// Dense two-phase simplex for: maximise c^T v subject to A v = b (b >= 0), v >= 0. Bland's rule
// (no cycling on the degenerate rows this problem has). Returns the basis of the optimum.
std::vector<std::size_t> simplex_max(const Eigen::MatrixXd& a, const Eigen::VectorXd& b, const Eigen::VectorXd& c) {
  const Eigen::Index m = a.rows(), n = a.cols();
  // Tableau with m artificial columns: [A I | b].
  Eigen::MatrixXd t = Eigen::MatrixXd::Zero(m, n + m + 1);
  t.leftCols(n) = a;
  t.block(0, n, m, m) = Eigen::MatrixXd::Identity(m, m);
  t.col(n + m) = b;
  std::vector<std::size_t> basis(static_cast<std::size_t>(m));
  for (Eigen::Index i = 0; i < m; ++i) basis[static_cast<std::size_t>(i)] = static_cast<std::size_t>(n + i);
  const double eps = 1e-11;

  auto pivot = [&](Eigen::Index r, Eigen::Index col) {
    t.row(r) /= t(r, col);
    for (Eigen::Index i = 0; i < m; ++i)
      if (i != r && t(i, col) != 0.0) t.row(i) -= t(i, col) * t.row(r);
    basis[static_cast<std::size_t>(r)] = static_cast<std::size_t>(col);
  };
  // Runs the simplex for the objective `cost` (maximise) over the columns < limit.
  auto run = [&](const Eigen::VectorXd& cost, Eigen::Index limit) {
    for (int iter = 0; iter < 100000; ++iter) {
      // Reduced costs: cost_j - cost_B^T column_j.
      Eigen::VectorXd cb(m);
      for (Eigen::Index i = 0; i < m; ++i) cb(i) = cost(static_cast<Eigen::Index>(basis[static_cast<std::size_t>(i)]));
      Eigen::Index enter = -1;
      for (Eigen::Index j = 0; j < limit; ++j) {
        const double rc = cost(j) - cb.dot(t.col(j));
        if (rc > eps) {
          enter = j;  // Bland: the lowest index that improves
          break;
        }
      }
      if (enter < 0) return;
      Eigen::Index leave = -1;
      double best = std::numeric_limits<double>::infinity();
      for (Eigen::Index i = 0; i < m; ++i) {
        if (t(i, enter) > eps) {
          const double ratio = t(i, n + m) / t(i, enter);
          if (ratio < best - eps || (ratio <= best + eps && leave >= 0 &&
                                     basis[static_cast<std::size_t>(i)] < basis[static_cast<std::size_t>(leave)])) {
            best = ratio;
            leave = i;
          }
        }
      }
      if (leave < 0) throw std::runtime_error("minimum zone: unbounded linear programme");
      pivot(leave, enter);
    }
    throw std::runtime_error("minimum zone: simplex did not converge");
  };
  // Phase 1: maximise -sum(artificials).
  Eigen::VectorXd c1 = Eigen::VectorXd::Zero(n + m);
  c1.tail(m).setConstant(-1.0);
  run(c1, n + m);
  // Drive remaining (zero-valued) artificials out of the basis where possible.
  for (Eigen::Index i = 0; i < m; ++i) {
    if (basis[static_cast<std::size_t>(i)] < static_cast<std::size_t>(n)) continue;
    for (Eigen::Index j = 0; j < n; ++j)
      if (std::abs(t(i, j)) > 1e-9) {
        pivot(i, j);
        break;
      }
  }
  Eigen::VectorXd c2 = Eigen::VectorXd::Zero(n + m);
  c2.head(n) = c;
  run(c2, n);
  return basis;
}

}  // namespace

MinimumZonePlane minimum_zone_flatness(const std::vector<double>& x, const std::vector<double>& y,
                                       const std::vector<double>& z) {
  const std::size_t n = x.size();
  if (y.size() != n || z.size() != n) throw std::invalid_argument("minimum_zone_flatness: x, y, z sizes differ");
  if (n < 3) throw std::invalid_argument("minimum_zone_flatness: need at least 3 points");
  // Scale to O(1) for the tolerances: coordinates by their span, heights by their span.
  const auto [x0, x1] = std::minmax_element(x.begin(), x.end());
  const auto [y0, y1] = std::minmax_element(y.begin(), y.end());
  const auto [z0, z1] = std::minmax_element(z.begin(), z.end());
  const double sx = std::max(*x1 - *x0, 1e-300), sy = std::max(*y1 - *y0, 1e-300);
  const double sz = *z1 - *z0;
  if (!(sz > 0)) return {0.0, 0.0, 0.0, *z0};
  // Dual of: min w s.t. a x_i + b y_i + c <= z_i <= a x_i + b y_i + c + w. Variables lambda_i (lower),
  // mu_i (upper) >= 0: max sum z_i (mu_i - lambda_i) s.t. sum x_i (mu_i - lambda_i) = 0,
  // sum y_i (mu_i - lambda_i) = 0, sum (mu_i - lambda_i) = 0, sum mu_i = 1.
  const auto nn = static_cast<Eigen::Index>(n);
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(4, 2 * nn);
  Eigen::VectorXd c(2 * nn);
  std::vector<double> xs(n), ys(n), zs(n);
  for (std::size_t i = 0; i < n; ++i) {
    xs[i] = (x[i] - *x0) / sx;
    ys[i] = (y[i] - *y0) / sy;
    zs[i] = (z[i] - *z0) / sz;
    const auto l = static_cast<Eigen::Index>(i), u = nn + l;
    a(0, l) = -xs[i], a(0, u) = xs[i];
    a(1, l) = -ys[i], a(1, u) = ys[i];
    a(2, l) = -1.0, a(2, u) = 1.0;
    a(3, u) = 1.0;
    c(l) = -zs[i], c(u) = zs[i];
  }
  Eigen::VectorXd b = Eigen::VectorXd::Zero(4);
  b(3) = 1.0;
  const auto basis = simplex_max(a, b, c);
  // Primal (a, b, c, w) = the simplex multipliers: B^T p = c_B over the basic columns.
  Eigen::Matrix4d bm = Eigen::Matrix4d::Zero();
  Eigen::Vector4d cb = Eigen::Vector4d::Zero();
  for (std::size_t i = 0; i < 4; ++i) {
    const auto j = static_cast<Eigen::Index>(basis[i]);
    if (j < 2 * nn) {
      bm.col(static_cast<Eigen::Index>(i)) = a.col(j);
      cb(static_cast<Eigen::Index>(i)) = c(j);
    } else {
      bm(static_cast<Eigen::Index>(j - 2 * nn), static_cast<Eigen::Index>(i)) = 1.0;  // artificial column
    }
  }
  const Eigen::Vector4d p = bm.transpose().fullPivLu().solve(cb);
  // Multipliers of rows 0, 1 are the slopes (scaled); the width follows from them exactly.
  const double as = p(0), bs = p(1);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (std::size_t i = 0; i < n; ++i) {
    const double d = zs[i] - as * xs[i] - bs * ys[i];
    lo = std::min(lo, d), hi = std::max(hi, d);
  }
  MinimumZonePlane r;
  r.width = (hi - lo) * sz;
  r.a = as * sz / sx;
  r.b = bs * sz / sy;
  r.c = *z0 + sz * lo - r.a * *x0 - r.b * *y0;
  return r;
}

}  // namespace guideway::models::flatness
