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
                         const Eigen::Ref<const Eigen::MatrixXd>& c, const Eigen::Ref<const Eigen::VectorXd>& qtr) {
  Eigen::MatrixXd g = x.transpose() * x;
  const Eigen::VectorXd norms = g.diagonal().cwiseSqrt();
  if (norms.minCoeff() > 0) {
    g.noalias() -= c.transpose() * c;
    const Eigen::VectorXd inv = norms.cwiseInverse();
    const Eigen::MatrixXd scaled = inv.asDiagonal() * g * inv.asDiagonal();
    const Eigen::VectorXd b = inv.asDiagonal() * (x.transpose() * m.residual - c.transpose() * qtr);
    if (const auto by_gram = extend_by_gram(m, scaled, b, crossed_min_diag)) return *by_gram;
  }
  Eigen::MatrixXd xp = x;
  subtract(m, c, xp);
  return extend_projected(m, std::move(xp), norms);
}

}  // namespace

double bic_of(double rss, double k, double m) { return m * std::log(floored(rss, m) / m) + k * std::log(m); }

double f_test(double rss0, double rss1, double q, double dof1, double m) {
  if (!(q > 0 && dof1 > 0)) return 1.0;
  const double a = floored(rss0, m), b = floored(rss1, m);
  return f_sf(((a - b) / q) / (b / dof1), q, dof1);
}

Model model_of(const GroupedBase& base, std::size_t skip, Eigen::MatrixXd terms, std::size_t searched,
               const Eigen::VectorXd& y) {
  const GroupedBase::Span& s = base.span(skip);
  Model m;
  m.base = &base;
  m.skip = skip;
  m.searched = searched;
  if (skip != GroupedBase::all) zero_rows(base.ranges(skip), terms);
  // Each column scaled to unit norm on the model's rows, then projected off the base's span (twice: classical
  // Gram-Schmidt loses orthogonality where a column lies near the span), its rank then decided as a joint pivoted
  // QR of the base's and its columns would (span_basis).
  for (Eigen::Index c = 0; c < terms.cols(); ++c)
    if (const double norm = terms.col(c).norm(); norm > 0) terms.col(c) /= norm;
  if (s.v.cols() > 0 && terms.cols() > 0)
    for (int pass = 0; pass < 2; ++pass) {
      const Eigen::MatrixXd c = s.v.transpose() * base.products(s, terms);
      base.subtract(s, s.v * c, terms);
    }
  m.qt = unit_span_basis(std::move(terms));
  m.residual = y;
  if (skip != GroupedBase::all) zero_rows(base.ranges(skip), m.residual);
  subtract(m, project(m, m.residual), m.residual);
  m.rss = m.residual.squaredNorm();
  m.rank = static_cast<std::size_t>(s.v.cols() + m.qt.cols()) + base.absorbed();
  m.bic = bic_of(m.rss, static_cast<double>(m.rank + searched), static_cast<double>(s.rows));
  return m;
}

Eigen::MatrixXd project(const Model& m, const Eigen::Ref<const Eigen::MatrixXd>& x) {
  const GroupedBase::Span& s = m.base->span(m.skip);
  const Eigen::Index rb = s.v.cols(), k = m.qt.cols();
  Eigen::MatrixXd c(rb + k, x.cols());
  if (rb > 0) c.topRows(rb) = s.v.transpose() * m.base->products(s, x);
  if (k > 0) c.bottomRows(k).noalias() = m.qt.transpose() * x;
  return c;
}

void subtract(const Model& m, const Eigen::Ref<const Eigen::MatrixXd>& c, Eigen::Ref<Eigen::MatrixXd> x) {
  const GroupedBase::Span& s = m.base->span(m.skip);
  const Eigen::Index rb = s.v.cols(), k = m.qt.cols();
  if (rb > 0) m.base->subtract(s, s.v * c.topRows(rb), x);
  if (k > 0) x.noalias() -= m.qt * c.bottomRows(k);
}

Extension extend(const Model& m, Eigen::MatrixXd x) {
  if (m.skip != GroupedBase::all) zero_rows(m.base->ranges(m.skip), x);
  const Eigen::VectorXd norms = x.colwise().norm().transpose();
  subtract(m, project(m, x), x);
  return extend_projected(m, std::move(x), norms);
}

Choice choose(const std::vector<Variant>& variants, const std::vector<bool>& allowed, const Model& m,
              std::vector<double>& buffer) {
  Choice best;
  double best_bic = 0;
  const auto count = static_cast<double>(m.base->span(m.skip).rows);
  const Eigen::Index n = m.residual.size();
  // The variants' products with the model's basis a batch at a time: one matrix product per batch instead
  // of a pass over the basis per variant (memory-bound at large n); a batch of at most ~2 MB of columns.
  const Eigen::Index batch_columns =
      std::clamp<Eigen::Index>((Eigen::Index{1} << 18) / std::max<Eigen::Index>(n, 1), 8, 64);
  const Eigen::MatrixXd qtr = project(m, m.residual);  // zero but for rounding
  std::size_t v = 0;
  while (v < variants.size()) {
    std::vector<std::size_t> members;
    Eigen::Index cols = 0;
    for (; v < variants.size() && (members.empty() || cols + width(variants[v]) <= batch_columns); ++v) {
      if (!allowed[v]) continue;
      members.push_back(v);
      cols += width(variants[v]);
    }
    if (members.empty()) continue;
    buffer.resize(std::max(buffer.size(), static_cast<std::size_t>(n * cols)));
    Eigen::Map<Eigen::MatrixXd> x(buffer.data(), n, cols);
    Eigen::Index at = 0;
    for (std::size_t k : members) {
      const Eigen::Index q = width(variants[k]);
      write_columns(variants[k], x.middleCols(at, q));
      at += q;
    }
    if (m.skip != GroupedBase::all) zero_rows(m.base->ranges(m.skip), x);  // the model's rows only
    const Eigen::MatrixXd c = project(m, x);
    at = 0;
    for (std::size_t k : members) {
      const Eigen::Index q = width(variants[k]);
      const Extension e = extend_crossed(m, x.middleCols(at, q), c.middleCols(at, q), qtr.col(0));
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
