// EXPLAIN's least squares on tall designs: blocked factorisations that stream the matrix once (subspace.hpp).
#include "models/explain/engine/subspace.hpp"

#include <algorithm>

#include <Eigen/Cholesky>
#include <Eigen/QR>

namespace guideway::models::explain::engine {

// The triangular factor of a tall matrix [a y] (y optional: a vector or none), R with R^T R = [a y]^T [a y],
// p + (y ? 1 : 0) rows: a QR of each chunk of rows that fits in a core's cache, then one of their factors
// stacked (a tall-skinny QR). One pass over the matrix: Householder QR of a whole n x p matrix of fewer than 32
// columns is one unblocked panel, p rank-one updates each streaming the whole matrix from memory (a tenth of
// explain()'s CPU at 18,000 samples per run). The column of y gives Q^T y with the same reflectors.
Eigen::MatrixXd tall_r_rows(Eigen::Index n, Eigen::Index w, const RowFiller& fill) {
  const Eigen::Index chunk = std::max<Eigen::Index>(2 * w, (Eigen::Index{1} << 17) / std::max<Eigen::Index>(w, 1));
  const auto factor = [w](Eigen::MatrixXd& m) {  // m's rows replaced by its R (at most w rows)
    if (m.rows() <= w) return;
    Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> h(m);
    m = Eigen::MatrixXd(h.matrixQR().topRows(w).triangularView<Eigen::Upper>());
  };
  Eigen::MatrixXd stacked(0, w);
  Eigen::MatrixXd part;
  for (Eigen::Index from = 0; from < n; from += chunk) {
    const Eigen::Index rows = std::min(chunk, n - from);
    part.resize(rows, w);
    fill(from, part);
    factor(part);
    stacked.conservativeResize(stacked.rows() + part.rows(), w);
    stacked.bottomRows(part.rows()) = part;
  }
  factor(stacked);
  if (stacked.rows() < w) stacked.conservativeResizeLike(Eigen::MatrixXd::Zero(w, w));
  return stacked;
}

Eigen::MatrixXd tall_r(const Eigen::Ref<const Eigen::MatrixXd>& a, const Eigen::VectorXd* y) {
  const Eigen::Index w = a.cols() + (y ? 1 : 0);
  return tall_r_rows(a.rows(), w, [&](Eigen::Index from, Eigen::Ref<Eigen::MatrixXd> part) {
    part.leftCols(a.cols()) = a.middleRows(from, part.rows());
    if (y) part.col(w - 1) = y->segment(from, part.rows());
  });
}

// Each column scaled to unit norm (a zero column kept); the scales applied.
Eigen::VectorXd scale_columns(Eigen::Ref<Eigen::MatrixXd> m) {
  Eigen::VectorXd scale(m.cols());
  for (Eigen::Index c = 0; c < m.cols(); ++c) {
    const double norm = m.col(c).norm();
    scale[c] = norm > 0 ? 1.0 / norm : 1.0;
    m.col(c) *= scale[c];
  }
  return scale;
}
// The minimum-norm solution of S b = y from the triangular factor r of [S y] (p + 1 columns): that of
// R0 b = (Q0^T y)[:p], the rank-revealing decomposition working on p x p.
Eigen::VectorXd min_norm_solution(const Eigen::MatrixXd& r, Eigen::Index p) {
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod;
  cod.setThreshold(rank_tolerance);
  cod.compute(r.topLeftCorner(p, p));
  return cod.solve(Eigen::VectorXd(r.col(p).head(p)));
}
// The held-out rows' prediction from a least-squares fit to the training rows (jt, yt): no uncertainties
// wanted, so the minimum-norm solution of the column-scaled problem by a complete orthogonal
// decomposition (rank as span_basis decides it). Minimum norm, not a basic solution: with columns the
// training rows cannot separate (Lai's unidentifiable terms) a basic solution's held-out prediction would
// depend on which column round-off pivots out. False when the fit fails.
// jt is scaled and decomposed in place.
bool predict(Eigen::MatrixXd jt, const Eigen::VectorXd& yt, const Eigen::MatrixXd& jh, Eigen::VectorXd& out) {
  const Eigen::Index p = jt.cols();
  if (p == 0) {  // nothing to fit (a base whose every column is zero): nothing predicted
    out = Eigen::VectorXd::Zero(jh.rows());
    return true;
  }
  const Eigen::VectorXd scale = scale_columns(jt);
  Eigen::VectorXd b;
  if (jt.rows() >= 2 * p) {
    b = min_norm_solution(tall_r(jt, &yt), p);  // a tall design reduced first (tall_r)
  } else {
    Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod;
    cod.setThreshold(rank_tolerance);
    cod.compute(jt);
    b = cod.solve(yt);
  }
  if (!b.allFinite()) return false;
  out = jh * (scale.asDiagonal() * b);
  return true;
}

FoldBase fold_base(Eigen::MatrixXd b) {
  FoldBase fb;
  fb.scale = scale_columns(b);
  const Eigen::HouseholderQR<Eigen::MatrixXd> h(b);
  fb.r = h.matrixQR().topRows(b.cols()).triangularView<Eigen::Upper>();
  fb.q = h.householderQ() * Eigen::MatrixXd::Identity(b.rows(), b.cols());
  return fb;
}

// predict() of the design [base rest] from the fold's factored base: [B R y] = [Q E'] [[R_B C] [0 R_E]] with
// C = Q^T [R y] and E = [R y] - Q C = E' R_E, so only E is factored (tall_r). The projection is done twice
// (classical Gram-Schmidt loses orthogonality to Q where a column lies near the base's span; twice is enough).
// jh: the held-out rows of the base's columns then rest's.
bool predict_beside(const FoldBase& base, Eigen::MatrixXd rest, const Eigen::VectorXd& yt, const Eigen::MatrixXd& jh,
                    Eigen::VectorXd& out) {
  const Eigen::Index pb = base.q.cols(), pr = rest.cols(), p = pb + pr;
  Eigen::MatrixXd e(rest.rows(), pr + 1);
  e.leftCols(pr) = rest;
  e.col(pr) = yt;
  Eigen::VectorXd scale(p);
  scale << base.scale, scale_columns(e.leftCols(pr));
  Eigen::MatrixXd c = base.q.transpose() * e;
  e.noalias() -= base.q * c;
  const Eigen::MatrixXd again = base.q.transpose() * e;
  e.noalias() -= base.q * again;
  c += again;
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(p + 1, p + 1);
  r.topLeftCorner(pb, pb) = base.r;
  r.topRightCorner(pb, pr + 1) = c;
  r.bottomRightCorner(pr + 1, pr + 1) = tall_r(e);
  const Eigen::VectorXd b = min_norm_solution(r, p);
  if (!b.allFinite()) return false;
  out = jh * (scale.asDiagonal() * b);
  return true;
}

namespace {

// The pivots above `tolerance` (absolute: the columns are of unit norm) of a column-pivoted QR.
template <class Qr>
Eigen::Index rank_above(const Qr& qr, double tolerance) {
  Eigen::Index r = 0;
  for (Eigen::Index i = 0; i < std::min(qr.matrixQR().rows(), qr.matrixQR().cols()); ++i)
    if (std::abs(qr.matrixQR()(i, i)) > tolerance) ++r;
  return r;
}

}  // namespace

ColumnsFit fit_of_columns(const Eigen::MatrixXd& r, const std::vector<Eigen::Index>& columns) {
  const Eigen::Index y = r.cols() - 1;
  Eigen::MatrixXd s(r.rows(), static_cast<Eigen::Index>(columns.size()));
  for (Eigen::Index c = 0; c < s.cols(); ++c) s.col(c) = r.col(columns[static_cast<std::size_t>(c)]);
  scale_columns(s);  // R's column norms are the design's (R^T R = S^T S)
  ColumnsFit out;
  out.rss = r.col(y).squaredNorm();
  if (s.cols() == 0) return out;
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(s);
  out.rank = rank_above(qr, rank_tolerance);
  const Eigen::VectorXd z = qr.householderQ().transpose() * r.col(y);
  out.rss = z.tail(z.size() - out.rank).squaredNorm();
  return out;
}

// A tall matrix is first reduced by a blocked unpivoted QR (S = Q0 R0: the pivoted QR of R0 pivots as S's, column
// norms being kept by Q0), and the basis formed as S_P R1^-1 with one Cholesky-QR pass to restore the
// orthogonality a triangular solve loses (its error ~ cond(R1) x eps, at most 1e-7 at the rank threshold).
// Both steps are matrix products: the unblocked pivoted QR of the whole n x p matrix was a fifth of
// explain()'s CPU at 18,000 samples per run.
Eigen::MatrixXd unit_span_basis(Eigen::MatrixXd s) {
  if (s.cols() == 0) return Eigen::MatrixXd(s.rows(), 0);
  const Eigen::Index p = s.cols();
  if (s.rows() >= 2 * p) {
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(tall_r(s));
    const Eigen::Index r = rank_above(qr, rank_tolerance);
    if (r == 0) return Eigen::MatrixXd(s.rows(), 0);
    const auto& perm = qr.colsPermutation().indices();
    Eigen::MatrixXd q(s.rows(), r);
    for (Eigen::Index c = 0; c < r; ++c) q.col(c) = s.col(perm[c]);
    const Eigen::MatrixXd r1 = qr.matrixR().topLeftCorner(r, r).triangularView<Eigen::Upper>();
    r1.triangularView<Eigen::Upper>().solveInPlace<Eigen::OnTheRight>(q);
    for (int pass = 0; pass < 2; ++pass) {
      const Eigen::MatrixXd g = q.transpose() * q;
      const Eigen::LLT<Eigen::MatrixXd> llt(g);
      if (llt.info() != Eigen::Success) break;
      llt.matrixU().solveInPlace<Eigen::OnTheRight>(q);
      if ((g - Eigen::MatrixXd::Identity(r, r)).cwiseAbs().maxCoeff() < 1e-12) break;
    }
    return q;
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(s);
  return qr.householderQ() * Eigen::MatrixXd::Identity(s.rows(), rank_above(qr, rank_tolerance));
}

Eigen::MatrixXd span_basis(Eigen::MatrixXd s) {
  for (Eigen::Index c = 0; c < s.cols(); ++c)
    if (const double norm = s.col(c).norm(); norm > 0) s.col(c) /= norm;
  return unit_span_basis(std::move(s));
}

}  // namespace guideway::models::explain::engine
