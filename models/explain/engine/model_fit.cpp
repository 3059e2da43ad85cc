// EXPLAIN's models: a design's basis and residual, and variants tried against it (model_fit.hpp).
#include "models/explain/engine/model_fit.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include <Eigen/Cholesky>
#include <Eigen/QR>

#include "models/explain/engine/subspace.hpp"
#include "models/explain/stats.hpp"

namespace guideway::models::explain::engine {

namespace {

// The finest residual level the tests resolve (um RMS): below it a residual counts as this level, so that
// noise-free data (a simulation, an exact fit) is not explained down to its rounding error.
constexpr double resolution_um = 1e-3;
double floored(double rss, double m) { return std::max(rss, m * resolution_um * resolution_um); }

// The joint fit from the Gram matrix g of x's columns projected off the model's span, each scaled by its norm
// before the projection, and b, their products with the model's residual: where the columns are well apart,
// a Cholesky with the largest diagonal first whose every pivot is at least gram_apart of the first (R's
// diagonal from a QR at least 1e-2 of its largest: g's condition at most 1e4, so b^T g^-1 b is exact to
// ~1e-12 relative) is of full rank whatever the rank test (rank_tolerance, 1e-9) decides. Nothing where the
// Gram matrix cannot decide: nearly collinear columns, a diagonal below min_diag (g from cross products
// loses what cancels) and the edge of "what is left is rounding" (|R00| < 1e-7) are decided by the
// column-pivoted QR of the projected columns, as before (the Gram matrix squares the condition: it could not
// resolve 1e-9).
constexpr double gram_apart = 1e-4;  // of the squared pivots
std::optional<Extension> extend_by_gram(const Model& m, const Eigen::MatrixXd& g, const Eigen::VectorXd& b,
                                        double min_diag) {
  if (g.rows() == 0 || !(g.diagonal().minCoeff() >= min_diag)) return std::nullopt;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(g);  // pivots on the largest diagonal left: a pivoted Cholesky
  const Eigen::VectorXd d = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || !(d.maxCoeff() > 4e-14) || !(d.minCoeff() >= gram_apart * d.maxCoeff()))
    return std::nullopt;
  return Extension{std::max(0.0, m.rss - b.dot(ldlt.solve(b))), static_cast<std::size_t>(g.rows())};
}

// As extend(), from xp = x - Q Q^T x and the norms of x's columns: by the Gram matrix where it decides (a
// pivoted QR of an n x 2 matrix streams it several times), else by the column-pivoted QR.
Extension extend_projected(const Model& m, Eigen::MatrixXd xp, const Eigen::VectorXd& norms) {
  // Relative to each column's own size before the projection: a column in the model's span adds nothing.
  for (Eigen::Index c = 0; c < xp.cols(); ++c) {
    if (norms[c] > 0)
      xp.col(c) /= norms[c];
    else
      xp.col(c).setZero();
  }
  Extension e{m.rss, 0};
  if (xp.cols() == 0 || xp.cwiseAbs().maxCoeff() < 1e-7) return e;
  if (const auto by_gram = extend_by_gram(m, xp.transpose() * xp, xp.transpose() * m.residual, 0.0)) return *by_gram;
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(xp);
  qr.setThreshold(rank_tolerance);
  if (std::abs(qr.matrixQR()(0, 0)) < 1e-7) return e;  // what is left of every column is rounding
  e.rank = static_cast<std::size_t>(qr.rank());
  const Eigen::VectorXd qtr = qr.householderQ().transpose() * m.residual;
  e.rss = std::max(0.0, m.rss - qtr.head(static_cast<Eigen::Index>(e.rank)).squaredNorm());
  return e;
}
// As extend(), from x's products with the model's basis, c = Q^T x, and qtr = Q^T r (r the model's
// residual): the Gram matrix of x's columns projected off Q is x^T x - c^T c, and their products with the
// residual x^T r - c^T qtr, so the projection itself is formed only where extend_by_gram cannot decide (a
// column that keeps less than a tenth of its norm off the model's span, whose Gram entries would lose
// digits to the cancellation: then 1e-12 relative at most).
constexpr double crossed_min_diag = 1e-2;
Extension extend_crossed(const Model& m, const Eigen::Ref<const Eigen::MatrixXd>& x,
                         const Eigen::Ref<const Eigen::MatrixXd>& c, const Eigen::VectorXd& qtr) {
  Eigen::MatrixXd g = x.transpose() * x;
  const Eigen::VectorXd norms = g.diagonal().cwiseSqrt();
  if (norms.minCoeff() > 0) {
    g.noalias() -= c.transpose() * c;
    const Eigen::VectorXd inv = norms.cwiseInverse();
    const Eigen::MatrixXd scaled = inv.asDiagonal() * g * inv.asDiagonal();
    const Eigen::VectorXd b = inv.asDiagonal() * (x.transpose() * m.residual - c.transpose() * qtr);
    if (const auto by_gram = extend_by_gram(m, scaled, b, crossed_min_diag)) return *by_gram;
  }
  return extend_projected(m, x - m.q * c, norms);
}

}  // namespace

double bic_of(double rss, double k, double m) { return m * std::log(floored(rss, m) / m) + k * std::log(m); }

double f_test(double rss0, double rss1, double q, double dof1, double m) {
  if (!(q > 0 && dof1 > 0)) return 1.0;
  const double a = floored(rss0, m), b = floored(rss1, m);
  return f_sf(((a - b) / q) / (b / dof1), q, dof1);
}

Model model_of(Eigen::MatrixXd j, std::size_t searched, const Eigen::VectorXd& y) {
  Model m;
  m.q = span_basis(std::move(j));
  m.residual = y - m.q * (m.q.transpose() * y);
  m.rss = m.residual.squaredNorm();
  m.rank = static_cast<std::size_t>(m.q.cols());
  m.searched = searched;
  m.bic = bic_of(m.rss, static_cast<double>(m.rank + searched), static_cast<double>(y.size()));
  return m;
}

Extension extend(const Model& m, const Eigen::MatrixXd& x) {
  return extend_projected(m, x - m.q * (m.q.transpose() * x), x.colwise().norm().transpose());
}
Choice choose(const std::vector<Variant>& variants, const std::vector<bool>& allowed,
              const std::vector<Eigen::Index>* rows, const Model& m, std::vector<double>& buffer) {
  Choice best;
  double best_bic = 0;
  const auto count = static_cast<double>(m.residual.size());
  // The variants' products with the model's basis a batch at a time: one matrix product per batch instead
  // of a pass over the n x rank basis per variant (memory-bound at large n).
  constexpr Eigen::Index batch_columns = 64;
  const Eigen::VectorXd qtr = m.q.transpose() * m.residual;  // zero but for rounding
  std::size_t v = 0;
  while (v < variants.size()) {
    std::vector<std::size_t> members;
    Eigen::Index width = 0;
    for (; v < variants.size() && (members.empty() || width + variants[v].block.columns.cols() <= batch_columns); ++v) {
      if (!allowed[v]) continue;
      members.push_back(v);
      width += variants[v].block.columns.cols();
    }
    if (members.empty()) continue;
    buffer.resize(std::max(buffer.size(), static_cast<std::size_t>(m.residual.size() * width)));
    Eigen::Map<Eigen::MatrixXd> x(buffer.data(), m.residual.size(), width);
    Eigen::Index at = 0;
    for (std::size_t k : members) {
      const auto& c = variants[k].block.columns;
      if (rows)
        x.middleCols(at, c.cols()) = c(*rows, Eigen::all);
      else
        x.middleCols(at, c.cols()) = c;
      at += c.cols();
    }
    const Eigen::MatrixXd c = m.q.transpose() * x;
    at = 0;
    for (std::size_t k : members) {
      const Eigen::Index q = variants[k].block.columns.cols();
      const Extension e = extend_crossed(m, x.middleCols(at, q), c.middleCols(at, q), qtr);
      at += q;
      if (e.rank == 0) continue;
      const double b = bic_of(e.rss, static_cast<double>(e.rank + variants[k].searched), count);
      if (best.index == none || b < best_bic) {
        best = {k, e};
        best_bic = b;
      }
    }
  }
  return best;
}

}  // namespace guideway::models::explain::engine
