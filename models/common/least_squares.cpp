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

}  // namespace

LsqResult solve_lsq(const Eigen::Ref<const Eigen::MatrixXd>& jacobian, const Eigen::VectorXd& y, const Eigen::VectorXd& weights,
                    const std::vector<std::string>& names, const LsqOptions& options) {
  LsqResult res;
  const Eigen::Index n = jacobian.rows();
  const Eigen::Index m = jacobian.cols();
  res.n = static_cast<std::size_t>(n);
  if (y.size() != n || (weights.size() != 0 && weights.size() != n) || static_cast<Eigen::Index>(names.size()) != m) {
    res.message = "least squares: inconsistent sizes of Jacobian, data, weights and names";
    return res;
  }
  if (m == 0) {
    res.message = "least squares: no parameters";
    return res;
  }
  if (n <= m) {
    res.message = "least squares: " + std::to_string(n) + " data points for " + std::to_string(m) +
                  " parameters; need more points than parameters";
    return res;
  }
  const auto non_finite = [&res] {
    res.message = "least squares: non-finite value (NaN or infinity) in the data";
    return res;
  };
  if (!y.allFinite() || (weights.size() != 0 && !weights.allFinite())) return non_finite();
  Eigen::VectorXd sw = Eigen::VectorXd::Ones(n);
  if (weights.size() != 0) sw = weights.cwiseMax(0.0).cwiseSqrt();

  // [W^1/2 J, W^1/2 y] = Q [R c; 0 d], Householder QR in one pass over J (Q is never formed); then
  // everything happens on the m x m triangle with c = Q^T W^1/2 y. The columns are scaled to unit
  // norm for the rank analysis: Householder QR is column-scale invariant, so R's columns are scaled
  // afterwards (the norm of a column of W^1/2 J is that of its column of R).
  const Eigen::MatrixXd raug = weighted_triangle(jacobian, y, sw);
  // A NaN or infinity anywhere in J reaches the diagonal of its column's R (every reflector that
  // touches it spreads it over the column, and its own reflector puts it on the diagonal), and finite
  // data give a finite R: J is scanned only when R says so, not before every fit.
  if (!raug.allFinite() && !jacobian.allFinite()) return non_finite();
  Eigen::VectorXd scale(m);
  Eigen::MatrixXd r = raug.topLeftCorner(m, m);
  for (Eigen::Index j = 0; j < m; ++j) {
    scale[j] = r.col(j).head(j + 1).norm();
    if (!(scale[j] > 0)) scale[j] = 1.0;
    r.col(j) /= scale[j];
  }
  const Eigen::VectorXd qtb = raug.col(m).head(m);

  Eigen::JacobiSVD<Eigen::MatrixXd> svd(r, Eigen::ComputeFullV);
  const auto& sv = svd.singularValues();
  const double smax = sv[0];
  const double smin = sv[m - 1];
  res.condition_number = smin > 0 ? smax / smin : std::numeric_limits<double>::infinity();
  std::size_t rank = 0;
  for (Eigen::Index i = 0; i < m; ++i)
    if (sv[i] > options.rank_tolerance * smax) ++rank;

  std::vector<bool> involved(static_cast<std::size_t>(m), false);
  if (rank < static_cast<std::size_t>(m)) {
    const Eigen::MatrixXd vnull = svd.matrixV().rightCols(m - static_cast<Eigen::Index>(rank));
    for (Eigen::Index j = 0; j < m; ++j)
      if (vnull.row(j).norm() > options.null_loading) involved[static_cast<std::size_t>(j)] = true;
  }
  // Keep every parameter outside the null space, then add the involved ones in order while the
  // columns stay independent; the rest are dropped (their effect is absorbed by kept ones).
  std::vector<Eigen::Index> kept;
  for (Eigen::Index j = 0; j < m; ++j)
    if (!involved[static_cast<std::size_t>(j)]) kept.push_back(j);
  std::vector<Eigen::Index> dropped;
  const auto columns = [&](const std::vector<Eigen::Index>& idx) {
    Eigen::MatrixXd c(m, static_cast<Eigen::Index>(idx.size()));
    for (std::size_t k = 0; k < idx.size(); ++k) c.col(static_cast<Eigen::Index>(k)) = r.col(idx[k]);
    return c;
  };
  for (Eigen::Index j = 0; j < m; ++j) {
    if (!involved[static_cast<std::size_t>(j)]) continue;
    auto trial = kept;
    trial.push_back(j);
    if (numerical_rank(columns(trial), options.rank_tolerance) == trial.size()) {
      kept = std::move(trial);
    } else {
      dropped.push_back(j);
    }
  }
  std::sort(kept.begin(), kept.end());

  const Eigen::MatrixXd rk = columns(kept);
  const auto k = static_cast<Eigen::Index>(kept.size());
  Eigen::HouseholderQR<Eigen::MatrixXd> qr2(rk);
  const Eigen::MatrixXd r2 = qr2.matrixQR().topRows(k).triangularView<Eigen::Upper>();
  const Eigen::VectorXd c2 = (qr2.householderQ().transpose() * qtb).head(k);
  const Eigen::VectorXd xs = r2.triangularView<Eigen::Upper>().solve(c2);
  const Eigen::MatrixXd rinv = r2.triangularView<Eigen::Upper>().solve(Eigen::MatrixXd::Identity(k, k));
  const Eigen::MatrixXd cov_s = rinv * rinv.transpose();

  res.x = Eigen::VectorXd::Zero(m);
  res.u = Eigen::VectorXd::Constant(m, std::numeric_limits<double>::quiet_NaN());
  res.covariance = Eigen::MatrixXd::Zero(m, m);
  res.identified.assign(static_cast<std::size_t>(m), false);
  Eigen::VectorXd x_all = Eigen::VectorXd::Zero(m);
  for (Eigen::Index i = 0; i < k; ++i)
    x_all[kept[static_cast<std::size_t>(i)]] = xs[i] / scale[kept[static_cast<std::size_t>(i)]];
  res.residual = y - jacobian * x_all;
  res.fitted = x_all;
  const Eigen::VectorXd wr = sw.cwiseProduct(res.residual);
  res.rank = static_cast<std::size_t>(k);
  res.s2 = wr.squaredNorm() / static_cast<double>(n - k);
  res.rms = std::sqrt(res.residual.squaredNorm() / static_cast<double>(n));
  for (Eigen::Index i = 0; i < k; ++i) {
    const Eigen::Index pi = kept[static_cast<std::size_t>(i)];
    for (Eigen::Index q = 0; q < k; ++q) {
      const Eigen::Index pq = kept[static_cast<std::size_t>(q)];
      res.covariance(pi, pq) = res.s2 * cov_s(i, q) / (scale[pi] * scale[pq]);
    }
  }
  for (Eigen::Index i = 0; i < k; ++i) {
    const Eigen::Index pi = kept[static_cast<std::size_t>(i)];
    if (involved[static_cast<std::size_t>(pi)]) continue;
    res.x[pi] = x_all[pi];
    res.u[pi] = std::sqrt(res.covariance(pi, pi));
    res.identified[static_cast<std::size_t>(pi)] = true;
  }
  for (Eigen::Index j = 0; j < m; ++j)
    if (involved[static_cast<std::size_t>(j)]) res.unidentifiable.push_back(names[static_cast<std::size_t>(j)]);

  // What the kept-but-involved estimates mean: kept_i absorbs beta_i * dropped_d.
  if (!dropped.empty()) {
    const Eigen::MatrixXd rd = columns(dropped);
    const Eigen::MatrixXd beta = rk.colPivHouseholderQr().solve(rd);  // k x |dropped|, in scaled units
    for (Eigen::Index i = 0; i < k; ++i) {
      const Eigen::Index pi = kept[static_cast<std::size_t>(i)];
      if (!involved[static_cast<std::size_t>(pi)]) continue;
      LsqCombination comb;
      comb.expression = names[static_cast<std::size_t>(pi)];
      comb.index.push_back(static_cast<std::size_t>(pi));
      comb.coefficient.push_back(1.0);
      for (std::size_t d = 0; d < dropped.size(); ++d) {
        const Eigen::Index pd = dropped[d];
        const double coef = beta(i, static_cast<Eigen::Index>(d)) * scale[pd] / scale[pi];
        if (std::abs(beta(i, static_cast<Eigen::Index>(d))) < 1e-9) continue;
        comb.expression +=
            (coef < 0 ? " - " : " + ") + format_coefficient(std::abs(coef)) + "*" + names[static_cast<std::size_t>(pd)];
        comb.index.push_back(static_cast<std::size_t>(pd));
        comb.coefficient.push_back(coef);
      }
      comb.value = x_all[pi];
      comb.u = std::sqrt(res.covariance(pi, pi));
      res.combinations.push_back(std::move(comb));
    }
  }
  for (Eigen::Index j = 0; j < m; ++j)
    if (involved[static_cast<std::size_t>(j)]) {
      for (Eigen::Index q = 0; q < m; ++q) {
        res.covariance(j, q) = 0.0;
        res.covariance(q, j) = 0.0;
      }
    }
  res.ok = true;
  if (!res.unidentifiable.empty()) {
    std::string list;
    for (const auto& s : res.unidentifiable) list += (list.empty() ? "" : ", ") + s;
    res.message = "the data cannot separate: " + list;
  }
  return res;
}

}  // namespace guideway::models
