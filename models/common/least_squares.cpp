// Weighted linear least squares with an identification's diagnostics (least_squares.hpp): uncertainties, condition,
// residuals.
#include "models/common/least_squares.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/QR>
#include <Eigen/SVD>

#include "models/common/householder_triangle.hpp"

namespace guideway::models {

namespace {

std::size_t numerical_rank(const Eigen::MatrixXd& m, double tol) {
  if (m.cols() == 0) return 0;
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(m);
  const auto& s = svd.singularValues();
  if (s.size() == 0 || s[0] <= 0) return 0;
  std::size_t r = 0;
  for (Eigen::Index i = 0; i < s.size(); ++i)
    if (s[i] > tol * s[0]) ++r;
  return r;
}

std::string format_coefficient(double c) {
  std::ostringstream o;
  o.precision(6);
  o << c;
  return o.str();
}

// The columns of `r` listed in `idx`.
Eigen::MatrixXd columns_of(const Eigen::MatrixXd& r, const std::vector<Eigen::Index>& idx) {
  Eigen::MatrixXd c(r.rows(), static_cast<Eigen::Index>(idx.size()));
  for (std::size_t k = 0; k < idx.size(); ++k) c.col(static_cast<Eigen::Index>(k)) = r.col(idx[k]);
  return c;
}

// Why the problem cannot be solved at all ("" = it can be tried): sizes that do not agree, no parameters,
// too few points.
std::string size_error(Eigen::Index n, Eigen::Index m, const Eigen::VectorXd& y, const Eigen::VectorXd& weights,
                       const std::vector<std::string>& names) {
  if (y.size() != n || (weights.size() != 0 && weights.size() != n) || static_cast<Eigen::Index>(names.size()) != m)
    return "least squares: inconsistent sizes of Jacobian, data, weights and names";
  if (m == 0) return "least squares: no parameters";
  if (n <= m)
    return "least squares: " + std::to_string(n) + " data points for " + std::to_string(m) +
           " parameters; need more points than parameters";
  return {};
}

// [W^1/2 J, W^1/2 y] = Q [R c; 0 d], Householder QR in one pass over J (Q is never formed); then
// everything happens on the m x m triangle with c = Q^T W^1/2 y. The columns are scaled to unit norm for
// the rank analysis: Householder QR is column-scale invariant, so R's columns are scaled afterwards (the
// norm of a column of W^1/2 J is that of its column of R).
struct ScaledTriangle {
  Eigen::MatrixXd r;      // R with unit-norm columns
  Eigen::VectorXd scale;  // the norms they were divided by
  Eigen::VectorXd qtb;    // c = Q^T W^1/2 y
};

ScaledTriangle scaled_triangle(const Eigen::MatrixXd& raug, Eigen::Index m) {
  ScaledTriangle t{raug.topLeftCorner(m, m), Eigen::VectorXd(m), raug.col(m).head(m)};
  for (Eigen::Index j = 0; j < m; ++j) {
    t.scale[j] = t.r.col(j).head(j + 1).norm();
    if (!(t.scale[j] > 0)) t.scale[j] = 1.0;
    t.r.col(j) /= t.scale[j];
  }
  return t;
}

// Which parameters the data cannot separate (those loading on the null space of the scaled R) and which
// columns are kept: every parameter outside the null space, then the involved ones in order while the
// columns stay independent; the rest are dropped (their effect is absorbed by kept ones).
struct Separation {
  std::vector<bool> involved;
  std::vector<Eigen::Index> kept, dropped;
  double condition_number = 0;
};

Separation separate(const Eigen::MatrixXd& r, const LsqOptions& options) {
  const Eigen::Index m = r.cols();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(r, Eigen::ComputeFullV);
  const auto& sv = svd.singularValues();
  const double smax = sv[0];
  const double smin = sv[m - 1];
  Separation s;
  s.condition_number = smin > 0 ? smax / smin : std::numeric_limits<double>::infinity();
  std::size_t rank = 0;
  for (Eigen::Index i = 0; i < m; ++i)
    if (sv[i] > options.rank_tolerance * smax) ++rank;
  s.involved.assign(static_cast<std::size_t>(m), false);
  if (rank < static_cast<std::size_t>(m)) {
    const Eigen::MatrixXd vnull = svd.matrixV().rightCols(m - static_cast<Eigen::Index>(rank));
    for (Eigen::Index j = 0; j < m; ++j)
      if (vnull.row(j).norm() > options.null_loading) s.involved[static_cast<std::size_t>(j)] = true;
  }
  for (Eigen::Index j = 0; j < m; ++j)
    if (!s.involved[static_cast<std::size_t>(j)]) s.kept.push_back(j);
  for (Eigen::Index j = 0; j < m; ++j) {
    if (!s.involved[static_cast<std::size_t>(j)]) continue;
    auto trial = s.kept;
    trial.push_back(j);
    if (numerical_rank(columns_of(r, trial), options.rank_tolerance) == trial.size()) {
      s.kept = std::move(trial);
    } else {
      s.dropped.push_back(j);
    }
  }
  std::sort(s.kept.begin(), s.kept.end());
  return s;
}

// The fit on the kept columns: estimates, residual, covariance (of the kept ones, in the parameters'
// units), u and `identified` of those outside the null space, the names of those inside.
void fit_kept(const ColumnBlocks& jacobian, const Eigen::VectorXd& y, const Eigen::VectorXd& sw,
              const std::vector<std::string>& names, const ScaledTriangle& t, const Separation& s, LsqResult& res) {
  const Eigen::Index n = y.size();
  const Eigen::Index m = t.r.cols();
  const Eigen::MatrixXd rk = columns_of(t.r, s.kept);
  const auto k = static_cast<Eigen::Index>(s.kept.size());
  Eigen::HouseholderQR<Eigen::MatrixXd> qr2(rk);
  const Eigen::MatrixXd r2 = qr2.matrixQR().topRows(k).triangularView<Eigen::Upper>();
  const Eigen::VectorXd c2 = (qr2.householderQ().transpose() * t.qtb).head(k);
  const Eigen::VectorXd xs = r2.triangularView<Eigen::Upper>().solve(c2);
  const Eigen::MatrixXd rinv = r2.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(k, k));
  const Eigen::MatrixXd cov_s = rinv * rinv.transpose();

  res.x = Eigen::VectorXd::Zero(m);
  res.u = Eigen::VectorXd::Constant(m, std::numeric_limits<double>::quiet_NaN());
  res.covariance = Eigen::MatrixXd::Zero(m, m);
  res.identified.assign(static_cast<std::size_t>(m), false);
  Eigen::VectorXd x_all = Eigen::VectorXd::Zero(m);
  for (Eigen::Index i = 0; i < k; ++i)
    x_all[s.kept[static_cast<std::size_t>(i)]] = xs[i] / t.scale[s.kept[static_cast<std::size_t>(i)]];
  res.residual = y;  // y - J x_all, as Eigen forms it (y, then J x_all subtracted), block by block
  Eigen::Index at = 0;
  for (const auto& b : jacobian) {
    res.residual.noalias() -= b * x_all.segment(at, b.cols());
    at += b.cols();
  }
  res.fitted = x_all;
  const Eigen::VectorXd wr = sw.cwiseProduct(res.residual);
  res.rank = static_cast<std::size_t>(k);
  res.s2 = wr.squaredNorm() / static_cast<double>(n - k);
  res.rms = std::sqrt(res.residual.squaredNorm() / static_cast<double>(n));
  for (Eigen::Index i = 0; i < k; ++i) {
    const Eigen::Index pi = s.kept[static_cast<std::size_t>(i)];
    for (Eigen::Index q = 0; q < k; ++q) {
      const Eigen::Index pq = s.kept[static_cast<std::size_t>(q)];
      res.covariance(pi, pq) = res.s2 * cov_s(i, q) / (t.scale[pi] * t.scale[pq]);
    }
  }
  for (Eigen::Index i = 0; i < k; ++i) {
    const Eigen::Index pi = s.kept[static_cast<std::size_t>(i)];
    if (s.involved[static_cast<std::size_t>(pi)]) continue;
    res.x[pi] = x_all[pi];
    res.u[pi] = std::sqrt(res.covariance(pi, pi));
    res.identified[static_cast<std::size_t>(pi)] = true;
  }
  for (Eigen::Index j = 0; j < m; ++j)
    if (s.involved[static_cast<std::size_t>(j)]) res.unidentifiable.push_back(names[static_cast<std::size_t>(j)]);
}

// What the kept-but-involved estimates mean: kept_i absorbs beta_i * dropped_d.
void add_combinations(const std::vector<std::string>& names, const ScaledTriangle& t, const Separation& s,
                      LsqResult& res) {
  if (s.dropped.empty()) return;
  const Eigen::MatrixXd rk = columns_of(t.r, s.kept);
  const Eigen::MatrixXd rd = columns_of(t.r, s.dropped);
  const Eigen::MatrixXd beta = rk.colPivHouseholderQr().solve(rd);  // k x |dropped|, in scaled units
  for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(s.kept.size()); ++i) {
    const Eigen::Index pi = s.kept[static_cast<std::size_t>(i)];
    if (!s.involved[static_cast<std::size_t>(pi)]) continue;
    LsqCombination comb;
    comb.expression = names[static_cast<std::size_t>(pi)];
    comb.index.push_back(static_cast<std::size_t>(pi));
    comb.coefficient.push_back(1.0);
    for (std::size_t d = 0; d < s.dropped.size(); ++d) {
      const Eigen::Index pd = s.dropped[d];
      const double coef = beta(i, static_cast<Eigen::Index>(d)) * t.scale[pd] / t.scale[pi];
      if (std::abs(beta(i, static_cast<Eigen::Index>(d))) < 1e-9) continue;
      comb.expression +=
          (coef < 0 ? " - " : " + ") + format_coefficient(std::abs(coef)) + "*" + names[static_cast<std::size_t>(pd)];
      comb.index.push_back(static_cast<std::size_t>(pd));
      comb.coefficient.push_back(coef);
    }
    comb.value = res.fitted[pi];
    comb.u = std::sqrt(res.covariance(pi, pi));
    res.combinations.push_back(std::move(comb));
  }
}

}  // namespace

LsqResult solve_lsq(const Eigen::Ref<const Eigen::MatrixXd>& jacobian, const Eigen::VectorXd& y,
                    const Eigen::VectorXd& weights, const std::vector<std::string>& names, const LsqOptions& options) {
  return solve_lsq(ColumnBlocks{jacobian}, y, weights, names, options);
}

LsqResult solve_lsq(const ColumnBlocks& jacobian, const Eigen::VectorXd& y, const Eigen::VectorXd& weights,
                    const std::vector<std::string>& names, const LsqOptions& options) {
  LsqResult res;
  const Eigen::Index n = jacobian.empty() ? y.size() : jacobian.front().rows();
  Eigen::Index m = 0;
  for (const auto& b : jacobian) {
    if (b.rows() != n) {
      res.message = "least squares: the blocks of the Jacobian have different numbers of rows";
      return res;
    }
    m += b.cols();
  }
  res.n = static_cast<std::size_t>(n);
  res.message = size_error(n, m, y, weights, names);
  if (!res.message.empty()) return res;
  const auto non_finite = [&res] {
    res.message = "least squares: non-finite value (NaN or infinity) in the data";
    return res;
  };
  if (!y.allFinite() || (weights.size() != 0 && !weights.allFinite())) return non_finite();
  Eigen::VectorXd sw = Eigen::VectorXd::Ones(n);
  if (weights.size() != 0) sw = weights.cwiseMax(0.0).cwiseSqrt();
  const Eigen::MatrixXd raug = weighted_triangle(jacobian, y, sw);
  // A NaN or infinity anywhere in J reaches the diagonal of its column's R (every reflector that
  // touches it spreads it over the column, and its own reflector puts it on the diagonal), and finite
  // data give a finite R: J is scanned only when R says so, not before every fit.
  if (!raug.allFinite() && std::any_of(jacobian.begin(), jacobian.end(), [](const auto& b) { return !b.allFinite(); }))
    return non_finite();
  const ScaledTriangle t = scaled_triangle(raug, m);
  const Separation s = separate(t.r, options);
  res.condition_number = s.condition_number;
  fit_kept(jacobian, y, sw, names, t, s, res);
  add_combinations(names, t, s, res);
  for (Eigen::Index j = 0; j < m; ++j)
    if (s.involved[static_cast<std::size_t>(j)]) {
      for (Eigen::Index q = 0; q < m; ++q) {
        res.covariance(j, q) = 0.0;
        res.covariance(q, j) = 0.0;
      }
    }
  res.ok = true;
  if (!res.unidentifiable.empty()) {
    std::string list;
    for (const auto& name : res.unidentifiable) list += (list.empty() ? "" : ", ") + name;
    res.message = "the data cannot separate: " + list;
  }
  return res;
}

}  // namespace guideway::models
