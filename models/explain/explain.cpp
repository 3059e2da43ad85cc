#include "models/explain/explain.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <tuple>
#include <type_traits>

#include <Eigen/Cholesky>
#include <Eigen/QR>
#include <Eigen/SVD>

#include "core/number_format.hpp"
#include "models/common/amplitude_phase.hpp"
#include "models/common/least_squares.hpp"
#include "models/explain/locate.hpp"
#include "models/explain/stats.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain {

namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();
constexpr std::size_t none = static_cast<std::size_t>(-1);

// The finest residual level the tests resolve (um RMS): below it a residual counts as this level, so that
// noise-free data (a simulation, an exact fit) is not explained down to its rounding error.
constexpr double resolution_um = 1e-3;
double floored(double rss, double m) { return std::max(rss, m * resolution_um * resolution_um); }

double bic_of(double rss, double k, double m) { return m * std::log(floored(rss, m) / m) + k * std::log(m); }

// F-test of the columns that take a model's RSS from rss0 to rss1 (q more rank, dof1 residual degrees of
// freedom left): the survival probability.
double f_test(double rss0, double rss1, double q, double dof1, double m) {
  if (!(q > 0 && dof1 > 0)) return 1.0;
  const double a = floored(rss0, m), b = floored(rss1, m);
  return f_sf(((a - b) / q) / (b / dof1), q, dof1);
}

// A direction whose pivot is below this fraction of the largest (columns scaled to unit norm, as
// solve_lsq's rank analysis) adds no rank.
constexpr double rank_tolerance = 1e-9;

// Memory the caches of models may hold (each an n x rank basis): at 100,000 samples per run one model is
// ~40 MB, so a count of entries alone would not bound it.
constexpr std::size_t cache_budget_bytes = std::size_t{256} << 20;

// The triangular factor of a tall matrix [a y] (y optional: a vector or none), R with R^T R = [a y]^T [a y],
// p + (y ? 1 : 0) rows: a QR of each chunk of rows that fits in a core's cache, then one of their factors
// stacked (a tall-skinny QR). One pass over the matrix: Householder QR of a whole n x p matrix of fewer than 32
// columns is one unblocked panel, p rank-one updates each streaming the whole matrix from memory (a tenth of
// explain()'s CPU at 18,000 samples per run). The column of y gives Q^T y with the same reflectors.
Eigen::MatrixXd tall_r(const Eigen::Ref<const Eigen::MatrixXd>& a, const Eigen::VectorXd* y = nullptr) {
  const Eigen::Index n = a.rows(), w = a.cols() + (y ? 1 : 0);
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
    part.leftCols(a.cols()) = a.middleRows(from, rows);
    if (y) part.col(w - 1) = y->segment(from, rows);
    factor(part);
    stacked.conservativeResize(stacked.rows() + part.rows(), w);
    stacked.bottomRows(part.rows()) = part;
  }
  factor(stacked);
  if (stacked.rows() < w) stacked.conservativeResizeLike(Eigen::MatrixXd::Zero(w, w));
  return stacked;
}

// The held-out rows' prediction from a least-squares fit to the training rows (jt, yt): no uncertainties
// wanted, so the minimum-norm solution of the column-scaled problem by a complete orthogonal
// decomposition (rank as span_basis decides it). Minimum norm, not a basic solution: with columns the
// training rows cannot separate (Lai's unidentifiable terms) a basic solution's held-out prediction would
// depend on which column round-off pivots out. False when the fit fails.
// jt is scaled and decomposed in place.
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
bool predict(Eigen::MatrixXd jt, const Eigen::VectorXd& yt, const Eigen::MatrixXd& jh, Eigen::VectorXd& out) {
  const Eigen::VectorXd scale = scale_columns(jt);
  Eigen::VectorXd b;
  const Eigen::Index p = jt.cols();
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

// A fold's base on its training rows, factored once: every held-out fit in that fold has the base's columns
// and differs only in the few columns of the effects beside it.
struct FoldBase {
  Eigen::VectorXd scale;  // predict()'s column scales
  Eigen::MatrixXd q, r;   // the scaled base = Q R, Q's columns orthonormal (Householder: whatever the base's rank)
};
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

// An orthonormal basis of the span of a's columns (each scaled to unit norm first: the base mixes units).
// The rank and the columns spanned are those of a column-pivoted QR (threshold rank_tolerance); a tall
// matrix is first reduced by a blocked unpivoted QR (S = Q0 R0: the pivoted QR of R0 pivots as S's, column
// norms being kept by Q0), and the basis formed as S_P R1^-1 with one Cholesky-QR pass to restore the
// orthogonality a triangular solve loses (its error ~ cond(R1) x eps, at most 1e-7 at the rank threshold).
// Both steps are matrix products: the unblocked pivoted QR of the whole n x p matrix was a fifth of
// explain()'s CPU at 18,000 samples per run.
Eigen::MatrixXd span_basis(Eigen::MatrixXd s) {
  if (s.cols() == 0) return Eigen::MatrixXd(s.rows(), 0);
  for (Eigen::Index c = 0; c < s.cols(); ++c)
    if (const double norm = s.col(c).norm(); norm > 0) s.col(c) /= norm;
  const Eigen::Index p = s.cols();
  if (s.rows() >= 2 * p) {
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(tall_r(s));
    qr.setThreshold(rank_tolerance);
    const Eigen::Index r = qr.rank();
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
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(s);
  qr.setThreshold(rank_tolerance);
  return qr.householderQ() * Eigen::MatrixXd::Identity(s.rows(), qr.rank());
}

// The least squares of a model on some rows, kept as an orthonormal basis of its columns and its residual,
// so that a variant can be tried against it exactly and cheaply (extend()).
struct Model {
  Eigen::MatrixXd q;
  Eigen::VectorXd residual;
  double rss = 0;
  std::size_t rank = 0;
  std::size_t searched = 0;  // nonlinear parameters found by search (counted in the BIC)
  double bic = 0;
};
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

// The joint least squares of a model and the columns x (same rows), from the model's basis and residual:
// x is projected off the model's span, and what is left of the residual in the span of the rest is removed.
struct Extension {
  double rss = 0;
  std::size_t rank = 0;  // added to the model's
};
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
Extension extend(const Model& m, const Eigen::MatrixXd& x) {
  return extend_projected(m, x - m.q * (m.q.transpose() * x), x.colwise().norm().transpose());
}

// The rows of each fold.
struct FoldRows {
  std::vector<Eigen::Index> train, test;
  std::vector<bool> use;  // use[i]: sample i is a training row of this fold
};
std::vector<FoldRows> fold_rows(const std::vector<int>& fold_of, int folds) {
  std::vector<FoldRows> out(static_cast<std::size_t>(folds));
  for (int f = 0; f < folds; ++f) {
    auto& fr = out[static_cast<std::size_t>(f)];
    fr.use.assign(fold_of.size(), false);
    for (std::size_t i = 0; i < fold_of.size(); ++i) {
      const bool held = fold_of[i] == f;
      (held ? fr.test : fr.train).push_back(static_cast<Eigen::Index>(i));
      fr.use[i] = !held;
    }
  }
  return out;
}

// A term's columns in one fold: of the variant chosen on that fold's training rows.
struct FoldBlock {
  Eigen::MatrixXd train, test;
  std::uint64_t id = 0;  // names these columns for the fold models' cache (0: none)
};
FoldBlock fold_block(const Variant& v, const FoldRows& fold) {
  static std::atomic<std::uint64_t> ids{0};
  return {v.block.columns(fold.train, Eigen::all), v.block.columns(fold.test, Eigen::all), ++ids};
}

// An effect in the model: its candidate, the variant chosen on all the data and, per fold, the columns
// of the variant chosen again on the fold's training rows (docs/explain.md "Held out").
struct Term {
  std::size_t cand = 0;
  std::shared_ptr<const std::vector<Variant>> pool;  // generated variants (null: the candidate's list)
  std::size_t index = 0;                             // the variant in the list
  double bonferroni = 1.0;                           // candidates x variants searched when it was taken
  std::size_t taken = 0;                             // when it was taken (findings are in this order)
  std::vector<FoldBlock> folds;
};

const std::vector<Variant>& listed(const Candidate& c, const std::shared_ptr<const std::vector<Variant>>& pool) {
  return pool ? *pool : c.variants;
}
const Variant& variant_of(const Problem& p, const Term& t) { return listed(p.candidates[t.cand], t.pool)[t.index]; }

// A variant may join the model when its candidate has no term yet (skip aside), or when every term of its
// candidate is of another, named group (a cyclic error on the other axis, a vibration along another direction).
bool group_free(const Problem& p, const Variant& v, std::size_t cand, const std::vector<Term>& terms,
                std::size_t skip) {
  for (std::size_t k = 0; k < terms.size(); ++k) {
    if (k == skip || terms[k].cand != cand) continue;
    if (v.group.empty() || variant_of(p, terms[k]).group == v.group) return false;
  }
  return true;
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

// A candidate's best variant against a model on some rows: the exact joint fit of each allowed variant,
// lowest BIC (n ln RSS + (rank + searched) ln n). rows = null: all rows. none: no variant can be fitted.
struct Choice {
  std::size_t index = none;
  Extension ext;
};
// `buffer` holds a batch's columns between calls: at large n a fresh n x 64 batch is an allocation the kernel
// clears page by page every time.
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

struct HeldOut {
  double rms = nan;
  std::string failure;           // why rms is NaN: a fold could not be fitted (not skipped: every figure
                                 // compared must average the same rows)
  std::vector<FoldBlock> trial;  // the trial's columns per fold (its term's when it is taken)
};

// A candidate tried against the model: its best variant, the joint fit and the tests of explain().
struct Trial {
  std::size_t cand = 0;
  std::shared_ptr<const std::vector<Variant>> pool;
  std::size_t index = none;
  Extension ext;
  double delta_bic = 0, p = 1, bonferroni = 1;
};

// Whether a term still earns its place in the model: the F-test, BIC and held-out RMS of the model
// without it against the model with it.
struct DropTest {
  double p = 1, delta_bic = 0, heldout_without = nan;
  bool earns = false;
  std::string why;  // when it does not
};

std::vector<ParamValue> params_of(const Variant& v, const LsqResult& f, Eigen::Index offset) {
  const auto q = v.block.columns.cols();
  Eigen::VectorXd x = f.x.segment(offset, q);
  Eigen::MatrixXd cov = f.covariance.block(offset, offset, q, q);
  std::vector<ParamValue> out;
  if (v.report) {
    out = v.report(x, cov);
  } else {
    for (Eigen::Index i = 0; i < q; ++i)
      out.push_back({v.block.names[static_cast<std::size_t>(i)], x[i], f.u[offset + i]});
  }
  out.insert(out.end(), v.fixed.begin(), v.fixed.end());
  return out;
}

class Selection {
 public:
  Selection(const Problem& problem, const ExplainOptions& options, const Eigen::VectorXd& y,
            std::vector<FoldRows> folds)
      : p_(problem), o_(options), y_(y), n_(static_cast<std::size_t>(y.size())), folds_(std::move(folds)) {
    const bool has_base = p_.base.columns.cols() > 0;
    for (const auto& f : folds_) {
      const auto rows = [&](const std::vector<Eigen::Index>& r) {
        return has_base ? Eigen::MatrixXd(p_.base.columns(r, Eigen::all))
                        : Eigen::MatrixXd(static_cast<Eigen::Index>(r.size()), 0);
      };
      base_train_.push_back(rows(f.train));
      base_test_.push_back(rows(f.test));
      y_train_.push_back(y_(f.train));
    }
  }

  // The columns of the base and the terms (but `skip`), on all rows.
  [[nodiscard]] Eigen::MatrixXd design(const std::vector<Term>& terms, std::size_t skip = none) const {
    Eigen::Index cols = p_.base.columns.cols();
    for (std::size_t k = 0; k < terms.size(); ++k)
      if (k != skip) cols += variant_of(p_, terms[k]).block.columns.cols();
    Eigen::MatrixXd j(static_cast<Eigen::Index>(n_), cols);
    Eigen::Index at = 0;
    if (p_.base.columns.cols() > 0) {
      j.leftCols(p_.base.columns.cols()) = p_.base.columns;
      at = p_.base.columns.cols();
    }
    for (std::size_t k = 0; k < terms.size(); ++k) {
      if (k == skip) continue;
      const auto& c = variant_of(p_, terms[k]).block.columns;
      j.middleCols(at, c.cols()) = c;
      at += c.cols();
    }
    return j;
  }
  [[nodiscard]] std::vector<std::string> names(const std::vector<Term>& terms) const {
    std::vector<std::string> out = p_.base.names;
    for (const auto& t : terms) {
      const auto& v = variant_of(p_, t).block.names;
      out.insert(out.end(), v.begin(), v.end());
    }
    return out;
  }
  [[nodiscard]] Model model(const std::vector<Term>& terms, std::size_t skip = none) const {
    const Key key = key_of(terms, skip);
    if (const auto it = models_.find(key); it != models_.end()) return it->second.value;
    std::size_t searched = 0;
    for (std::size_t k = 0; k < terms.size(); ++k)
      if (k != skip) searched += variant_of(p_, terms[k]).searched;
    Model m = model_of(design(terms, skip), searched, y_);
    remember(models_, key, terms, m);
    return m;
  }

  // The candidate's variants for a residual (zero on the rows not in use) and which may join the terms.
  std::shared_ptr<const std::vector<Variant>> generate(const Candidate& c, const Eigen::VectorXd& r,
                                                       const std::vector<bool>& use) const {
    if (!c.generate) return nullptr;
    auto pool = std::make_shared<const std::vector<Variant>>(c.generate(r, use));
    for (const auto& v : *pool)
      if (static_cast<std::size_t>(v.block.columns.rows()) != n_)
        throw std::invalid_argument("explain: candidate " + c.effect + " has the wrong number of rows");
    return pool;
  }
  [[nodiscard]] std::vector<bool> allowed(std::size_t cand, const std::vector<Variant>& variants,
                                          const std::vector<Term>& terms, std::size_t skip) const {
    std::vector<bool> a(variants.size());
    for (std::size_t v = 0; v < variants.size(); ++v) a[v] = group_free(p_, variants[v], cand, terms, skip);
    return a;
  }

  // Candidate c tried against the model `cur` of the terms: its best variant on all the data and the
  // F-test (Bonferroni over `live` candidates and the grid points searched) and BIC against cur.
  [[nodiscard]] Trial trial(std::size_t c, const std::vector<Term>& terms, const Model& cur) const {
    const Candidate& cand = p_.candidates[c];
    Trial t;
    t.cand = c;
    t.pool = generate(cand, cur.residual, std::vector<bool>(n_, true));
    const auto& variants = listed(cand, t.pool);
    const Choice ch = choose(variants, allowed(c, variants, terms, none), nullptr, cur, choose_buffer_);
    if (ch.index == none) return t;
    t.index = ch.index;
    t.ext = ch.ext;
    const auto m = static_cast<double>(n_);
    const auto& v = variants[t.index];
    t.delta_bic =
        bic_of(ch.ext.rss, static_cast<double>(cur.rank + ch.ext.rank + cur.searched + v.searched), m) - cur.bic;
    t.bonferroni = static_cast<double>(cand.search_size ? cand.search_size : std::max<std::size_t>(variants.size(), 1));
    const double q = static_cast<double>(ch.ext.rank), dof2 = m - static_cast<double>(cur.rank + ch.ext.rank);
    t.p = f_test(cur.rss, ch.ext.rss, q, dof2, m);
    return t;
  }

  // Held-out RMS: every fold's held-out rows predicted from a fit to its training rows of the base, the
  // terms (but `skip`, each with the variant chosen on that fold's training rows) and the trial candidate,
  // if any. With ExplainOptions::heldout_reselect (the default) the trial's variant is chosen again in each
  // fold from the training rows alone, as every term's was -- a generator gets the training residual, zero
  // on the held-out rows, and the mask of the training rows; otherwise the variant chosen on all the data
  // (`fixed`) is taken and only the coefficients are refitted, which is optimistic (the held-out rows took
  // part in the choice; bench/explain_heldout_bench.cpp). A fold that cannot be fitted makes it NaN.
  [[nodiscard]] HeldOut heldout(const std::vector<Term>& terms, std::size_t skip, std::size_t trial = none,
                                const Variant* fixed = nullptr) const {
    if (trial == none) {
      const Key key = key_of(terms, skip);
      if (const auto it = heldouts_.find(key); it != heldouts_.end()) return it->second.value;
      HeldOut h = heldout_uncached(terms, skip, none, nullptr);
      remember(heldouts_, key, terms, h);
      return h;
    }
    return heldout_uncached(terms, skip, trial, fixed);
  }
  [[nodiscard]] HeldOut heldout_uncached(const std::vector<Term>& terms, std::size_t skip, std::size_t trial,
                                         const Variant* fixed) const {
    HeldOut out;
    Eigen::Index columns = p_.base.columns.cols();
    for (std::size_t k = 0; k < terms.size(); ++k)
      if (k != skip) columns += variant_of(p_, terms[k]).block.columns.cols();
    if (columns == 0 && trial == none) {
      out.rms = std::sqrt(y_.squaredNorm() / static_cast<double>(n_));
      return out;
    }
    out.trial.resize(folds_.size());
    double sse = 0;
    std::size_t count = 0;
    for (std::size_t f = 0; f < folds_.size(); ++f) {
      const FoldRows& fold = folds_[f];
      if (fold.test.empty()) continue;
      const auto fail = [&](const std::string& why) {
        HeldOut failed;
        failed.failure = "fold " + std::to_string(f + 1) + " of " + std::to_string(folds_.size()) + ": " + why;
        return failed;
      };
      const Eigen::VectorXd& yt = y_train_[f];
      if (trial != none) {
        const Candidate& cand = p_.candidates[trial];
        const Variant* chosen = fixed;
        std::shared_ptr<const std::vector<Variant>> pool;
        if (o_.heldout_reselect) {
          const Model& m = fold_model(f, terms, skip);
          Eigen::VectorXd r = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n_));
          r(fold.train) = m.residual;
          pool = generate(cand, r, fold.use);
          const auto& variants = listed(cand, pool);
          const Choice ch = choose(variants, allowed(trial, variants, terms, skip), &fold.train, m, choose_buffer_);
          if (ch.index == none) return fail(cand.effect + " has no variant that can be fitted on the training rows");
          chosen = &variants[ch.index];
        }
        out.trial[f] = fold_block(*chosen, fold);
      }
      // Built once with the trial's columns (no concatenated copies: at large n each copy of the fold's
      // design is an allocation the kernel clears page by page, a tenth of explain()'s CPU).
      const Eigen::MatrixXd* extra_train = trial != none ? &out.trial[f].train : nullptr;
      const Eigen::MatrixXd jh = fold_columns(f, terms, skip, false, trial != none ? &out.trial[f].test : nullptr);
      if (fold.train.size() < static_cast<std::size_t>(jh.cols()) + 2)
        return fail(std::to_string(fold.train.size()) + " training rows for " + std::to_string(jh.cols()) + " columns");
      Eigen::VectorXd predicted;
      const auto base = fold.train.size() >= 2 * static_cast<std::size_t>(jh.cols() + 1) ? fold_base_of(f) : nullptr;
      const bool fitted =
          base ? predict_beside(*base, fold_columns(f, terms, skip, true, extra_train, false), yt, jh, predicted)
               : predict(fold_columns(f, terms, skip, true, extra_train), yt, jh, predicted);
      if (!fitted) return fail("the fit failed (not finite)");
      sse += (y_(fold.test) - predicted).squaredNorm();
      count += fold.test.size();
    }
    out.rms = count ? std::sqrt(sse / static_cast<double>(count)) : nan;
    return out;
  }

  // Term k's variant chosen again with the others in the model (on all the data and in every fold):
  // chosen before a later effect was taken, it may have absorbed part of that effect. True if it changed.
  bool rechoose(std::vector<Term>& terms, std::size_t k) const {
    Term& t = terms[k];
    const Candidate& cand = p_.candidates[t.cand];
    if (!cand.generate && cand.variants.size() < 2) return false;
    const Model without = model(terms, k);
    auto pool = generate(cand, without.residual, std::vector<bool>(n_, true));
    const auto& variants = listed(cand, pool);
    const Choice ch = choose(variants, allowed(t.cand, variants, terms, k), nullptr, without, choose_buffer_);
    if (ch.index == none) return false;
    const Variant& now = variants[ch.index];
    const Variant& before = variant_of(p_, t);
    if (now.block.columns.cols() == before.block.columns.cols() &&
        (now.block.columns - before.block.columns).cwiseAbs().maxCoeff() <=
            1e-12 * (1 + before.block.columns.cwiseAbs().maxCoeff()))
      return false;
    t.pool = pool;
    t.index = ch.index;
    refold(terms, k);
    return true;
  }

  // Terms i and j re-chosen together on all the data: every variant of i (generated against the model
  // without i) with j's best given it; the pair whose joint fit has the lowest BIC replaces theirs when that
  // is lower than now. Two effects whose shapes overlap (a deadband taken up late and a reversal spike) can
  // each be the best given the other while another pair fits better, and re-choosing one at a time stays
  // there. True if the pair changed (then both are chosen again in every fold).
  bool rechoose_pair(std::vector<Term>& terms, std::size_t i, std::size_t j) const {
    const Candidate& ci = p_.candidates[terms[i].cand];
    const Candidate& cj = p_.candidates[terms[j].cand];
    if ((!ci.generate && ci.variants.size() < 2) || (!cj.generate && cj.variants.size() < 2)) return false;
    // Terms that share (almost) nothing cannot stand in for each other: not searched (a deadband and a
    // spike share 0.17; most pairs of the scenario suite below 0.03).
    if (overlap(variant_of(p_, terms[i]).block.columns, variant_of(p_, terms[j]).block.columns) < 0.1) return false;
    const auto pool_i = generate(ci, model(terms, i).residual, std::vector<bool>(n_, true));
    const auto& vi = listed(ci, pool_i);
    const std::vector<bool> ok = allowed(terms[i].cand, vi, terms, i);
    std::vector<Term> trial = terms;
    double best = model(terms).bic;
    std::optional<std::pair<Term, Term>> better;
    for (std::size_t v = 0; v < vi.size(); ++v) {
      if (!ok[v]) continue;
      trial[i].pool = pool_i;
      trial[i].index = v;
      std::size_t searched = 0;
      for (std::size_t k = 0; k < trial.size(); ++k)
        if (k != j) searched += variant_of(p_, trial[k]).searched;
      const Model without_j = model_of(design(trial, j), searched, y_);  // not cached: one use each
      const auto pool_j = generate(cj, without_j.residual, std::vector<bool>(n_, true));
      const auto& vj = listed(cj, pool_j);
      const Choice ch = choose(vj, allowed(trial[j].cand, vj, trial, j), nullptr, without_j, choose_buffer_);
      if (ch.index == none) continue;
      const double bic =
          bic_of(ch.ext.rss, static_cast<double>(without_j.rank + ch.ext.rank + searched + vj[ch.index].searched),
                 static_cast<double>(n_));
      if (bic < best - 1e-9 * std::abs(best)) {
        best = bic;
        Term tj = trial[j];
        tj.pool = pool_j;
        tj.index = ch.index;
        better.emplace(trial[i], std::move(tj));
      }
    }
    if (!better) return false;
    terms[i] = std::move(better->first);
    terms[j] = std::move(better->second);
    refold(terms, i);
    refold(terms, j);
    return true;
  }

  // How much two blocks of columns share: the largest canonical correlation of their spans (the cosine
  // of the smallest angle between them), 0 when one has no columns.
  static double overlap(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
    if (a.cols() == 0 || b.cols() == 0) return 0.0;
    const Eigen::MatrixXd qa = span_basis(a), qb = span_basis(b);
    if (qa.cols() == 0 || qb.cols() == 0) return 0.0;
    const Eigen::MatrixXd c = qa.transpose() * qb;
    return Eigen::JacobiSVD<Eigen::MatrixXd>(c).singularValues()[0];
  }

  // Term k's columns in every fold: its variant chosen again on the fold's training rows
  // (ExplainOptions::heldout_reselect), else the one chosen on all the data.
  void refold(std::vector<Term>& terms, std::size_t k) const {
    Term& t = terms[k];
    const Candidate& cand = p_.candidates[t.cand];
    const Variant& now = variant_of(p_, t);
    for (std::size_t f = 0; f < folds_.size(); ++f) {
      const FoldRows& fold = folds_[f];
      if (fold.test.empty()) continue;
      if (!o_.heldout_reselect) {
        t.folds[f] = fold_block(now, fold);
        continue;
      }
      const Model& m = fold_model(f, terms, k);
      Eigen::VectorXd r = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n_));
      r(fold.train) = m.residual;
      auto fpool = generate(cand, r, fold.use);
      const auto& fv = listed(cand, fpool);
      const Choice fc = choose(fv, allowed(t.cand, fv, terms, k), &fold.train, m, choose_buffer_);
      if (fc.index == none) continue;  // the fold keeps its earlier choice, made on its training rows too
      t.folds[f] = fold_block(fv[fc.index], fold);
    }
  }

  // Term k against the model without it: the F-test (Bonferroni as when it was taken) and the BIC.
  [[nodiscard]] DropTest significance(const std::vector<Term>& terms, std::size_t k, const Model& cur) const {
    DropTest d;
    const Model without = model(terms, k);
    const auto m = static_cast<double>(n_);
    const double q = static_cast<double>(cur.rank) - static_cast<double>(without.rank);
    const double dof2 = m - static_cast<double>(cur.rank);
    d.p = std::min(1.0, f_test(without.rss, cur.rss, q, dof2, m) * terms[k].bonferroni);
    d.delta_bic = cur.bic - without.bic;
    return d;
  }

  // Does term k still earn its place with the others in the model (`cur`, held-out cur_heldout)?
  [[nodiscard]] DropTest drop_test(const std::vector<Term>& terms, std::size_t k, const Model& cur,
                                   double cur_heldout) const {
    DropTest d = significance(terms, k, cur);
    if (!(d.p < o_.alpha)) {
      d.why = "not significant with the others in the model (p=" + printf_number("%.2g", d.p) + ")";
      return d;
    }
    if (!(d.delta_bic < 0)) {
      d.why = "does not lower the BIC with the others in the model";
      return d;
    }
    d.heldout_without = heldout(terms, k).rms;
    if (std::isfinite(cur_heldout) && std::isfinite(d.heldout_without) && !(cur_heldout < d.heldout_without)) {
      d.why = "the held-out RMS is no worse without it (" + printf_number("%.4g", d.heldout_without) + " um)";
      return d;
    }
    d.earns = true;
    return d;
  }

  // Term k's parameters, their u widened by the searched parameters' uncertainty: over every other variant
  // of its list that the data leave plausible -- the joint RSS within s^2 of the chosen one, the 1-sigma
  // region of the profile likelihood -- the largest change of each parameter is added in quadrature.
  // (u from the covariance alone is conditional on the searched value: a spike's decay one grid step off
  // halves its amplitude.)
  [[nodiscard]] std::vector<ParamValue> widened(const std::vector<Term>& terms, std::size_t k, const Model& cur,
                                                const std::vector<ParamValue>& chosen) const {
    const Term& t = terms[k];
    const auto& variants = listed(p_.candidates[t.cand], t.pool);
    if (variants.size() < 2) return chosen;
    const double s2 = cur.rss / std::max(1.0, static_cast<double>(n_) - static_cast<double>(cur.rank));
    const Model without = model(terms, k);
    const auto ok = allowed(t.cand, variants, terms, k);
    std::vector<ParamValue> out = chosen;
    std::vector<double> spread(out.size(), 0.0);
    for (std::size_t v = 0; v < variants.size(); ++v) {
      if (v == t.index || !ok[v]) continue;
      const Extension e = extend(without, variants[v].block.columns);
      if (e.rank == 0 || !(e.rss - cur.rss < s2)) continue;
      std::vector<Term> alt = terms;
      alt[k].index = v;
      const LsqResult fit = solve_lsq(design(alt), y_, Eigen::VectorXd(), names(alt));
      if (!fit.ok) continue;
      Eigen::Index offset = p_.base.columns.cols();
      for (std::size_t j = 0; j < k; ++j) offset += variant_of(p_, terms[j]).block.columns.cols();
      for (const ParamValue& q : params_of(variants[v], fit, offset))
        for (std::size_t i = 0; i < out.size(); ++i)
          if (out[i].name == q.name && std::isfinite(out[i].u))
            spread[i] = std::max(spread[i], std::abs(q.value - out[i].value));
    }
    for (std::size_t i = 0; i < out.size(); ++i) out[i].u = std::hypot(out[i].u, spread[i]);
    return out;
  }

  // Share of the structure left without term k that the model with it removes: visible energy of the
  // bands located in the residual without it, against that of the residual with it. NaN when nothing is
  // structured without it (a term below visibility is judged by the tests alone).
  [[nodiscard]] double share(const std::vector<Term>& terms, std::size_t k, const Model& cur, double sigma,
                             double floor) const {
    const Model without = model(terms, k);
    const Located here = locate(p_, without.residual, o_.alpha, sigma);
    if (!here.structured) return nan;
    const double before = visible_energy(p_, without.residual, sigma, here.flagged);
    if (!(before > floor)) return nan;
    return 1.0 - visible_energy(p_, cur.residual, sigma, here.flagged) / before;
  }

 private:
  // Models and held-out figures of the same set of terms are asked for again and again (drop-one tests,
  // shares, re-choices): kept by the set of variants. A variant's address identifies it while its list
  // lives, and an entry keeps the generated lists of its terms alive, so an address is never reused
  // for another variant while its entry exists.
  using Key = std::vector<const Variant*>;
  [[nodiscard]] Key key_of(const std::vector<Term>& terms, std::size_t skip) const {
    Key k;
    for (std::size_t j = 0; j < terms.size(); ++j)
      if (j != skip) k.push_back(&variant_of(p_, terms[j]));
    std::sort(k.begin(), k.end());
    return k;
  }
  template <class V>
  struct Entry {
    V value;
    std::vector<std::shared_ptr<const std::vector<Variant>>> pools;
  };
  template <class V>
  void remember(std::map<Key, Entry<V>>& cache, const Key& key, const std::vector<Term>& terms, const V& value) const {
    Entry<V> e{value, {}};
    std::size_t bytes = 0;
    if constexpr (std::is_same_v<V, Model>) bytes += static_cast<std::size_t>(value.q.size() + value.residual.size());
    for (const auto& t : terms)
      if (t.pool) {
        e.pools.push_back(t.pool);
        for (const auto& v : *t.pool) bytes += static_cast<std::size_t>(v.block.columns.size());
      }
    bytes *= sizeof(double);
    // Bounds the memory: each model holds an n x rank basis, each entry the generated variants it keeps alive.
    std::size_t& held = std::is_same_v<V, Model> ? model_bytes_ : heldout_bytes_;
    if (cache.size() >= 64 || held + bytes > cache_budget_bytes) {
      cache.clear();
      held = 0;
    }
    held += bytes;
    cache.emplace(key, std::move(e));
  }
  mutable std::size_t model_bytes_ = 0, heldout_bytes_ = 0;
  mutable std::map<Key, Entry<Model>> models_;
  mutable std::map<Key, Entry<HeldOut>> heldouts_;

  // The model of the base and the terms (but `skip`) on fold f's training rows, kept by the columns' ids
  // (a term's fold columns depend on when they were chosen, not only on its variant): every trial of a
  // forward step and every re-choice is fitted against the same fold models.
  [[nodiscard]] const Model& fold_model(std::size_t f, const std::vector<Term>& terms, std::size_t skip) const {
    std::vector<std::uint64_t> key{f};
    for (std::size_t k = 0; k < terms.size(); ++k)
      if (k != skip) key.push_back(terms[k].folds[f].id);
    std::sort(key.begin() + 1, key.end());
    if (std::find(key.begin() + 1, key.end(), 0) == key.end())
      if (const auto it = fold_models_.find(key); it != fold_models_.end()) return it->second;
    Model m = model_of(fold_columns(f, terms, skip, true), 0, y_train_[f]);
    const std::size_t bytes = static_cast<std::size_t>(m.q.size() + m.residual.size()) * sizeof(double);
    if (fold_model_bytes_ + bytes > cache_budget_bytes) {
      fold_models_.clear();
      fold_model_bytes_ = 0;
    }
    fold_model_bytes_ += bytes;
    return fold_models_.insert_or_assign(std::move(key), std::move(m)).first->second;
  }
  mutable std::map<std::vector<std::uint64_t>, Model> fold_models_;
  mutable std::size_t fold_model_bytes_ = 0;

  // Fold f's base factored on its training rows, kept within the memory budget; null without a base, and
  // at the fold's first held-out fit (factoring the base and forming its Q costs two plain fits: a problem
  // whose base alone is tested, a null, never fits a fold twice).
  [[nodiscard]] std::shared_ptr<const FoldBase> fold_base_of(std::size_t f) const {
    if (base_train_[f].cols() == 0) return nullptr;
    if (fold_bases_.empty()) fold_bases_.resize(folds_.size());
    if (fold_bases_[f]) return fold_bases_[f];
    if (fold_fits_.size() < folds_.size()) fold_fits_.resize(folds_.size(), 0);
    if (fold_fits_[f]++ == 0) return nullptr;
    auto fb = std::make_shared<const FoldBase>(fold_base(base_train_[f]));
    const auto bytes = static_cast<std::size_t>(fb->q.size()) * sizeof(double);
    if (fold_base_bytes_ + bytes <= cache_budget_bytes) {
      fold_base_bytes_ += bytes;
      fold_bases_[f] = fb;
    }
    return fb;
  }
  mutable std::vector<std::shared_ptr<const FoldBase>> fold_bases_;
  mutable std::vector<int> fold_fits_;  // held-out fits per fold so far
  mutable std::size_t fold_base_bytes_ = 0;

  // Fold f's columns of the base (unless with_base is false) and the terms (but `skip`) on its training or
  // held-out rows, and `extra`'s (a trial's on the same rows) after them.
  [[nodiscard]] Eigen::MatrixXd fold_columns(std::size_t f, const std::vector<Term>& terms, std::size_t skip,
                                             bool train, const Eigen::MatrixXd* extra = nullptr,
                                             bool with_base = true) const {
    const Eigen::MatrixXd& base = train ? base_train_[f] : base_test_[f];
    const Eigen::Index base_cols = with_base ? base.cols() : 0;
    Eigen::Index cols = base_cols + (extra ? extra->cols() : 0);
    for (std::size_t k = 0; k < terms.size(); ++k)
      if (k != skip) cols += (train ? terms[k].folds[f].train : terms[k].folds[f].test).cols();
    Eigen::MatrixXd j(base.rows(), cols);
    if (base_cols > 0) j.leftCols(base_cols) = base;
    Eigen::Index at = base_cols;
    for (std::size_t k = 0; k < terms.size(); ++k) {
      if (k == skip) continue;
      const Eigen::MatrixXd& b = train ? terms[k].folds[f].train : terms[k].folds[f].test;
      j.middleCols(at, b.cols()) = b;
      at += b.cols();
    }
    if (extra) j.rightCols(extra->cols()) = *extra;
    return j;
  }

  const Problem& p_;
  const ExplainOptions& o_;
  const Eigen::VectorXd& y_;
  std::size_t n_;
  std::vector<FoldRows> folds_;
  mutable std::vector<double> choose_buffer_;  // choose()'s batches
  std::vector<Eigen::MatrixXd> base_train_, base_test_;
  std::vector<Eigen::VectorXd> y_train_;
};

// Residual curves on the first run's grid (sorted, decimated); other runs interpolated onto it. One step
// per entry of `steps` (the base model, then after each finding).
void add_curves(Report& rep, const Problem& problem, const std::vector<std::pair<std::string, Eigen::VectorXd>>& steps,
                std::size_t max_points) {
  if (max_points == 0 || steps.empty()) return;
  const auto ranges = run_ranges(problem);
  const auto sorted_run = [&](std::size_t k, const Eigen::VectorXd& r) {
    std::vector<std::pair<double, double>> xy;
    for (std::size_t i = ranges[k].first; i < ranges[k].second; ++i) {
      double w = problem.samples[i].where;
      if (problem.domain == "angle_deg") w = std::fmod(std::fmod(w, 360.0) + 360.0, 360.0);
      xy.emplace_back(w, r[static_cast<Eigen::Index>(i)]);
    }
    std::sort(xy.begin(), xy.end());
    return xy;
  };
  const auto at = [](const std::vector<std::pair<double, double>>& xy, double x) {
    auto it = std::lower_bound(xy.begin(), xy.end(), std::make_pair(x, -1e300));
    if (it == xy.begin()) return xy.front().second;
    if (it == xy.end()) return xy.back().second;
    const auto& hi = *it;
    const auto& lo = *(it - 1);
    return hi.first == lo.first ? hi.second
                                : lo.second + (hi.second - lo.second) * (x - lo.first) / (hi.first - lo.first);
  };
  const auto grid_src = sorted_run(0, steps.front().second);
  if (grid_src.empty()) return;
  const std::size_t stride = (grid_src.size() + max_points - 1) / max_points;
  for (std::size_t i = 0; i < grid_src.size(); i += stride) rep.curve_x.push_back(grid_src[i].first);
  rep.curve_domain = problem.domain;
  for (std::size_t k = 0; k < ranges.size(); ++k)
    if (ranges[k].second > ranges[k].first) rep.curve_runs.push_back(problem.runs[k].label);
  for (const auto& [label, residual] : steps) {
    ResidualStep step{label, {}};
    for (std::size_t k = 0; k < ranges.size(); ++k) {
      if (ranges[k].second == ranges[k].first) continue;
      const auto xy = sorted_run(k, residual);
      std::vector<double> v;
      v.reserve(rep.curve_x.size());
      for (double x : rep.curve_x) v.push_back(at(xy, x));
      step.residual_um.push_back(std::move(v));
    }
    rep.curve_steps.push_back(std::move(step));
  }
}

}  // namespace

namespace {

// What is explained, one value per sample; refuses too few samples, a base of the wrong size, non-finite
// samples and candidates of the wrong size.
Eigen::VectorXd observations(const Problem& problem) {
  const std::size_t n = problem.samples.size();
  if (n < 32) throw std::invalid_argument("explain: too few samples (" + std::to_string(n) + ", need 32)");
  if (problem.base.columns.cols() > 0 && static_cast<std::size_t>(problem.base.columns.rows()) != n)
    throw std::invalid_argument("explain: base design has the wrong number of rows");
  Eigen::VectorXd y(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    y[static_cast<Eigen::Index>(i)] = problem.samples[i].y_um;
    if (!std::isfinite(problem.samples[i].y_um)) throw std::invalid_argument("explain: non-finite sample");
  }
  for (const auto& c : problem.candidates)
    for (const auto& v : c.variants)
      if (static_cast<std::size_t>(v.block.columns.rows()) != n)
        throw std::invalid_argument("explain: candidate " + c.effect + " has the wrong number of rows");
  return y;
}

// The held-out rows: whole runs when there are at least three, the base is still determined without any
// one of them and no candidate has terms of one run alone; otherwise contiguous blocks of every run
// (staggered between runs).
struct HeldOutScheme {
  std::vector<int> fold_of;
  int folds = 0;
  std::string name;
};

HeldOutScheme heldout_scheme(const Problem& problem, const ExplainOptions& options,
                             const std::vector<std::pair<std::size_t, std::size_t>>& ranges) {
  const std::size_t n = problem.samples.size();
  HeldOutScheme h{std::vector<int>(n, 0), static_cast<int>(std::max<std::size_t>(options.folds, 2)), {}};
  bool loro = false;
  if (problem.runs.size() >= 3 && !problem.terms_per_run && problem.base.columns.cols() > 0) {
    const std::size_t full_rank = static_cast<std::size_t>(span_basis(problem.base.columns).cols());
    loro = true;
    for (std::size_t k = 0; k < ranges.size() && loro; ++k) {
      std::vector<Eigen::Index> train;
      for (std::size_t i = 0; i < n; ++i)
        if (problem.samples[i].run != k) train.push_back(static_cast<Eigen::Index>(i));
      loro = static_cast<std::size_t>(span_basis(problem.base.columns(train, Eigen::all)).cols()) == full_rank;
    }
  }
  if (loro) {
    h.folds = static_cast<int>(problem.runs.size());
    for (std::size_t i = 0; i < n; ++i) h.fold_of[i] = static_cast<int>(problem.samples[i].run);
    h.name = "leave-one-run-out (" + std::to_string(h.folds) + " runs)";
    return h;
  }
  for (std::size_t k = 0; k < ranges.size(); ++k) {
    const auto [a, b] = ranges[k];
    const std::size_t len = b - a;
    for (std::size_t i = a; i < b; ++i) {
      const auto block = static_cast<int>((i - a) * static_cast<std::size_t>(h.folds) / std::max<std::size_t>(len, 1));
      h.fold_of[i] = (block + static_cast<int>(k)) % h.folds;
    }
  }
  h.name = "blocked " + std::to_string(h.folds) + "-fold cross-validation (contiguous blocks of every run)";
  return h;
}

// The set of effects (docs/explain.md "Name and fit"): forward selection on the tests, each earlier choice
// re-decided and re-tested whenever an effect joins, then every effect's share of the structure left
// without it; what is dropped is not tried again.
class EffectSelection {
 public:
  // From the base model `base` and its held-out figure.
  EffectSelection(const Problem& problem, const ExplainOptions& options, const Selection& sel, Model base,
                  HeldOut base_heldout, double sigma, double visible_floor)
      : p_(problem),
        o_(options),
        sel_(sel),
        sigma_(sigma),
        visible_floor_(visible_floor),
        nc_(problem.candidates.size()),
        cur_(std::move(base)),
        cur_ho_(std::move(base_heldout)),
        cur_heldout_(cur_ho_.rms),
        banned_(nc_, false),
        verdict_(nc_) {}

  void run() {
    bool changed = true;
    for (std::size_t guard = 0; changed && guard < 4 * nc_ + 4; ++guard) {
      changed = false;
      while (terms_.size() < o_.max_effects) {
        const std::string accepted = forward_step();
        if (accepted.empty()) break;
        changed = true;
        // Earlier choices re-decided with the new effect in the model (a deadband sized, a line picked,
        // while this effect was still in the residual), then re-tested.
        for (std::size_t k = 0; k + 1 < terms_.size(); ++k) sel_.rechoose(terms_, k);
        // The new effect with each earlier one (pairs of earlier effects were searched when the later joined).
        for (std::size_t i = 0; i + 1 < terms_.size(); ++i) sel_.rechoose_pair(terms_, i, terms_.size() - 1);
        refresh();
        prune(accepted);
      }
      changed = drop_partial_fits() || changed;
    }
    // The findings in the order taken.
    std::sort(terms_.begin(), terms_.end(), [](const Term& a, const Term& b) { return a.taken < b.taken; });
  }

  [[nodiscard]] const std::vector<Term>& terms() const { return terms_; }
  // The effects held when the share rule first dropped one (partial fits of a cause outside the library
  // among them): their residual shows such a cause where the base's is structured throughout.
  [[nodiscard]] const std::optional<std::vector<Term>>& before_share() const { return before_share_; }
  [[nodiscard]] const Model& model() const { return cur_; }
  [[nodiscard]] double heldout() const { return cur_heldout_; }
  // The latest verdict of every candidate without a term, lowest delta BIC first.
  [[nodiscard]] std::vector<Considered> considered() const {
    std::vector<Considered> out;
    for (std::size_t c = 0; c < nc_; ++c)
      if (verdict_[c] && !has_term(c)) out.push_back(*verdict_[c]);
    std::stable_sort(out.begin(), out.end(),
                     [](const Considered& a, const Considered& b) { return a.delta_bic < b.delta_bic; });
    return out;
  }

 private:
  void refresh() {
    cur_ = sel_.model(terms_);
    cur_ho_ = sel_.heldout(terms_, none);
    cur_heldout_ = cur_ho_.rms;
  }

  [[nodiscard]] bool has_term(std::size_t c) const {
    return std::any_of(terms_.begin(), terms_.end(), [&](const Term& t) { return t.cand == c; });
  }

  void drop(std::size_t k, Considered why) {
    const std::size_t c = terms_[k].cand;
    terms_.erase(terms_.begin() + static_cast<std::ptrdiff_t>(k));
    banned_[c] = true;
    if (!has_term(c)) verdict_[c] = std::move(why);
    refresh();
  }

  // Drop-one: every effect kept must still pass the tests with the others in the model.
  void prune(const std::string& after) {
    while (!terms_.empty()) {
      std::size_t worst = none;
      DropTest wd;
      for (std::size_t k = 0; k < terms_.size(); ++k) {
        DropTest d = sel_.drop_test(terms_, k, cur_, cur_heldout_);
        if (!d.earns && (worst == none || d.p > wd.p)) {
          worst = k;
          wd = std::move(d);
        }
      }
      if (worst == none) return;
      drop(worst,
           {p_.candidates[terms_[worst].cand].effect, wd.delta_bic, wd.p, "dropped after " + after + ": " + wd.why});
    }
  }

  // Every candidate not banned tried against the model, Bonferroni over the trials, lowest BIC first.
  std::vector<Trial> trials() const {
    std::vector<Trial> out;
    for (std::size_t c = 0; c < nc_; ++c) {
      const Candidate& cand = p_.candidates[c];
      if (banned_[c] || (cand.variants.empty() && !cand.generate)) continue;
      if (o_.on_progress)
        o_.on_progress("looking for effect " + std::to_string(terms_.size() + 1) + ": trying " + cand.effect + " (" +
                       std::to_string(c + 1) + " of " + std::to_string(nc_) + ")");
      Trial t = sel_.trial(c, terms_, cur_);
      if (t.index != none) out.push_back(std::move(t));
    }
    for (auto& t : out) {
      t.bonferroni *= static_cast<double>(out.size());
      t.p = std::min(1.0, t.p * t.bonferroni);
    }
    std::sort(out.begin(), out.end(), [](const Trial& a, const Trial& b) { return a.delta_bic < b.delta_bic; });
    return out;
  }

  // One forward step: the best trial that passes the F-test, lowers the BIC and improves the held-out RMS
  // joins the model; every other trial's verdict is kept. Returns the effect taken ("" = none).
  std::string forward_step() {
    std::string accepted;
    for (auto& t : trials()) {
      const Candidate& cand = p_.candidates[t.cand];
      Considered con{cand.effect, t.delta_bic, t.p, ""};
      if (!accepted.empty()) {
        con.verdict = "not tried after a better candidate was taken";
      } else if (!(t.p < o_.alpha)) {
        con.verdict = "not significant (p=" + printf_number("%.2g", t.p) + ")";
      } else if (!(t.delta_bic < 0)) {
        con.verdict = "does not lower the BIC";
      } else if (!std::isfinite(cur_heldout_)) {  // no figure to beat: the trial's is not computed
        con.verdict = "held-out RMS of the model so far not computable (" + cur_ho_.failure + ")";
      } else {
        const Variant& v = listed(cand, t.pool)[t.index];
        HeldOut ho = sel_.heldout(terms_, none, t.cand, &v);
        if (!std::isfinite(ho.rms)) {
          con.verdict = "held-out RMS not computable (" + ho.failure + ")";
        } else if (!(ho.rms < cur_heldout_)) {
          con.verdict = "held-out RMS not improved (" + printf_number("%.4g", ho.rms) + " um)";
        } else {
          con.verdict = "selected";
          accepted = cand.effect;
          terms_.push_back({t.cand, t.pool, t.index, t.bonferroni, taken_++, std::move(ho.trial)});
          verdict_[t.cand].reset();
          continue;
        }
      }
      if (!has_term(t.cand)) verdict_[t.cand] = std::move(con);
    }
    return accepted;
  }

  // Each effect must remove most of the structure left without it: a partial fit of a cause it is not
  // leaves that cause's shape behind. Not when nothing is left above the noise: no shape is left behind, and
  // the share is then of the noise (a traverse's drift at t = 7.7 "removed only 69-80 %" at 26 of 100 seeds).
  // Returns whether one was dropped.
  bool drop_partial_fits() {
    bool changed = false;
    while (!terms_.empty()) {
      const Located left = locate(p_, cur_.residual, o_.alpha, sigma_);
      if (!left.structured || !(left.visible_energy > 0)) break;
      std::size_t worst = none;
      double worst_share = 1.0;
      for (std::size_t k = 0; k < terms_.size(); ++k) {
        const double s = sel_.share(terms_, k, cur_, sigma_, visible_floor_);
        if (std::isfinite(s) && s < o_.min_share && (worst == none || s < worst_share)) {
          worst = k;
          worst_share = s;
        }
      }
      if (worst == none) break;
      if (!before_share_) before_share_ = terms_;
      const std::string effect = p_.candidates[terms_[worst].cand].effect;
      const DropTest d = sel_.significance(terms_, worst, cur_);
      drop(worst, {effect, d.delta_bic, d.p,
                   "removes only " + printf_number("%.0f", 100 * worst_share) + " % of the structure left without it"});
      prune("dropping " + effect);
      changed = true;
    }
    return changed;
  }

  const Problem& p_;
  const ExplainOptions& o_;
  const Selection& sel_;
  double sigma_, visible_floor_;
  std::size_t nc_;
  std::vector<Term> terms_;
  Model cur_;
  HeldOut cur_ho_;
  double cur_heldout_ = nan;
  std::vector<bool> banned_;
  std::vector<std::optional<Considered>> verdict_;  // the latest, for candidates without a term
  std::optional<std::vector<Term>> before_share_;
  std::size_t taken_ = 0;
};

// A finding's fitted term's size: as the model measures it, else its peak-to-valley over each run.
void set_contribution(const Problem& problem, const std::vector<std::pair<std::size_t, std::size_t>>& ranges,
                      const Eigen::VectorXd& term, Finding& fd) {
  if (problem.contribution_of) {
    fd.contribution_um = problem.contribution_of(term);
  } else {
    for (const auto& [a, b] : ranges) {
      if (b <= a) continue;
      const auto seg = term.segment(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b - a));
      fd.contribution_um = std::max(fd.contribution_um, seg.maxCoeff() - seg.minCoeff());
    }
  }
  if (problem.deviation_um > 0) fd.contribution_percent = 100 * fd.contribution_um / problem.deviation_um;
}

// The findings in the order taken: parameters from the final joint fit; the BIC, p-value and share of each
// against the final model without it; RMS and held-out RMS after each in turn. `steps` gets the residual
// after each.
void add_findings(const Problem& problem, const Selection& sel, const EffectSelection& chosen, const Eigen::VectorXd& y,
                  double sigma, double visible_floor, bool keep_columns, Report& rep,
                  std::vector<std::pair<std::string, Eigen::VectorXd>>& steps) {
  const std::vector<Term>& terms = chosen.terms();
  const std::size_t n = problem.samples.size();
  const auto ranges = run_ranges(problem);
  const LsqResult final_fit = solve_lsq(sel.design(terms), y, Eigen::VectorXd(), sel.names(terms));
  if (!final_fit.ok) throw std::invalid_argument("explain: least squares failed: " + final_fit.message);
  Eigen::Index offset = problem.base.columns.cols();
  for (std::size_t k = 0; k < terms.size(); ++k) {
    const Candidate& cand = problem.candidates[terms[k].cand];
    const Variant& v = variant_of(problem, terms[k]);
    const std::vector<Term> prefix(terms.begin(), terms.begin() + static_cast<std::ptrdiff_t>(k + 1));
    const Model pm = sel.model(prefix);
    const DropTest d = sel.significance(terms, k, chosen.model());
    Finding fd;
    fd.effect = cand.effect;
    fd.parameters = sel.widened(terms, k, chosen.model(), params_of(v, final_fit, offset));
    fd.delta_bic = d.delta_bic;
    fd.p_value = d.p;
    fd.rms_um_after = std::sqrt(pm.rss / static_cast<double>(n));
    fd.heldout_rms_um_after = k + 1 == terms.size() ? chosen.heldout() : sel.heldout(prefix, none).rms;
    fd.share = sel.share(terms, k, chosen.model(), sigma, visible_floor);
    set_contribution(problem, ranges, v.block.columns * final_fit.x.segment(offset, v.block.columns.cols()), fd);
    fd.why = cand.why;
    if (keep_columns) {
      // Over every sample of the runs, also when some were set aside: the shape is the effect's wherever
      // it was fitted (a model that fits it beside its own terms needs every sample's value).
      const Eigen::MatrixXd& all = v.columns_all_samples.size() > 0 ? v.columns_all_samples : v.block.columns;
      fd.column_names = v.block.names;
      for (Eigen::Index c = 0; c < all.cols(); ++c)
        fd.columns_um.emplace_back(all.col(c).data(), all.col(c).data() + all.rows());
    }
    rep.findings.push_back(std::move(fd));
    steps.emplace_back("+ " + cand.effect, pm.residual);
    offset += v.block.columns.cols();
  }
}

}  // namespace

namespace {

// The verdict on what is left: `unexplained`, with its places, when the residual is structured and some of
// it stands above the noise (a place, or "throughout"). A residual significant only as a whole -- not white,
// or a band's energy raised, with no coefficient above the universal threshold -- has no place a user could
// look at and nothing an effect could be tested on beyond the noise: it is not `unexplained` but a note
// (docs/explain.md step 5). Before, it was `unexplained` "below the noise everywhere", which a borderline
// whiteness test turned on and off between live runs of the same machine.
void settle_verdict(const Located& fin, Report& rep) {
  if (!fin.structured || fin.visible_energy > 0) {
    rep.remaining = fin.places;
    rep.unexplained = fin.structured;
    return;
  }
  rep.unexplained = false;
  const std::string evidence = fin.places.empty() ? std::string() : " (" + fin.places.front().evidence + ")";
  rep.notes.push_back(
      "the residual left is not white noise" + evidence +
      ", but no part of it stands above the noise: correlated noise at the noise level, with no place to look at "
      "and nothing an effect could be tested on; not reported as unexplained");
}

// A finding's term as the whole problem sees it: its candidate and variant, and a generated variant's columns
// over every sample of the problem given to explain() (a listed variant's are that problem's own).
struct TermColumns {
  std::size_t cand = 0, index = 0;
  bool generated = false;
  Eigen::MatrixXd all_samples;
};

struct Pass {
  Report report;
  // Where the residual of the effects held before the share rule dropped any is structured, place by
  // place (empty: none dropped, or structured throughout).
  std::vector<Location> probe;
  std::vector<TermColumns> terms;  // the findings' terms, in the order taken
};

Pass explain_once(const Problem& problem, const ExplainOptions& options) {
  const Eigen::VectorXd y = observations(problem);
  const std::size_t n = problem.samples.size();
  const auto ranges = run_ranges(problem);
  Report rep;
  rep.model = problem.model;
  rep.n = n;
  rep.notes = problem.notes;
  const HeldOutScheme scheme = heldout_scheme(problem, options, ranges);
  rep.heldout_scheme = scheme.name;

  const Selection sel(problem, options, y, fold_rows(scheme.fold_of, scheme.folds));
  const Model base = sel.model({});
  const HeldOut base_ho = sel.heldout({}, none);
  // Every effect will be refused for it: say why once, whether or not a candidate gets that far.
  if (!base_ho.failure.empty())
    rep.notes.push_back("held-out RMS of the base not computable (" + base_ho.failure + ")");
  rep.baseline = {std::sqrt(base.rss / static_cast<double>(n)), base.bic, base_ho.rms, base.rank + base.searched};
  const Located base_loc = locate(problem, base.residual, options.alpha);
  rep.noise_um = base_loc.sigma_um;
  rep.mismatch = base_loc.places;
  const double sigma = base_loc.sigma_um;
  // Energy a denoised pure-noise residual keeps is tiny; below this nothing is "visible".
  const double visible_floor = 1e-3 * sigma * sigma * static_cast<double>(n);

  EffectSelection chosen(problem, options, sel, base, base_ho, sigma, visible_floor);
  chosen.run();
  std::vector<std::pair<std::string, Eigen::VectorXd>> steps{{"base model", sel.model({}).residual}};
  add_findings(problem, sel, chosen, y, sigma, visible_floor, options.keep_columns, rep, steps);
  rep.considered = chosen.considered();
  const Model& cur = chosen.model();
  rep.final_fit = {std::sqrt(cur.rss / static_cast<double>(n)), cur.bic, chosen.heldout(), cur.rank + cur.searched};
  rep.deviation_um = problem.deviation_um;
  rep.deviation_name = problem.deviation_name;
  add_curves(rep, problem, steps, options.curve_points);
  const Located fin = locate(problem, cur.residual, options.alpha);
  settle_verdict(fin, rep);
  Pass pass{std::move(rep), {}, {}};
  for (const Term& t : chosen.terms()) {
    const Variant& v = variant_of(problem, t);
    pass.terms.push_back({t.cand, t.index, t.pool != nullptr,
                          v.columns_all_samples.size() > 0 ? v.columns_all_samples : v.block.columns});
  }
  if (pass.report.unexplained && chosen.before_share()) {
    const Located probe = locate(problem, sel.model(*chosen.before_share()).residual, options.alpha, sigma);
    for (const auto& m : probe.places) pass.probe.insert(pass.probe.end(), m.locations.begin(), m.locations.end());
  }
  return pass;
}

// The problem without the samples `keep` leaves out: the base's and every listed variant's rows dropped,
// each generator given the whole residual (zero on the rows left out) with those rows out of use, its
// variants' rows dropped; a contribution measured on the whole sample grid (a left-out sample takes its
// run's nearest kept value).
struct Reduced {
  Problem problem;
  std::vector<Eigen::Index> kept;  // the whole problem's index of each sample
};
// `after`: for each place set aside, its run and the first sample after it; from there on (and in every later
// run) the reading may stand off by a constant, a nuisance column of the base (a step, such as a ball
// slipping in its socket, leaves the data after it offset from the data before it, whatever is set aside).
bool stands_off(const Problem& p, std::pair<std::size_t, std::size_t> after, std::size_t sample) {
  const std::size_t r = p.samples[sample].run;
  return r > after.first || (r == after.first && sample >= after.second);
}

// `keep_whole`: every variant keeps its block over all samples (Variant::columns_all_samples), for the
// findings' columns (ExplainOptions::keep_columns); a generated variant always does (it is made per call, and
// the places set aside are checked against the findings over every sample: explain()).
Reduced without_samples(const Problem& p, const std::vector<bool>& keep,
                        const std::vector<std::pair<std::size_t, std::size_t>>& after, bool keep_whole) {
  Reduced out;
  for (std::size_t i = 0; i < keep.size(); ++i)
    if (keep[i]) out.kept.push_back(static_cast<Eigen::Index>(i));
  const auto kept = std::make_shared<const std::vector<Eigen::Index>>(out.kept);
  const auto n = static_cast<Eigen::Index>(p.samples.size());
  Problem& q = out.problem;
  q = p;
  q.samples.clear();
  for (const Eigen::Index i : *kept) q.samples.push_back(p.samples[static_cast<std::size_t>(i)]);
  if (p.base.columns.cols() > 0) q.base.columns = p.base.columns(*kept, Eigen::all);
  if (!after.empty()) {
    const Eigen::Index b = q.base.columns.cols();
    q.base.columns.conservativeResize(static_cast<Eigen::Index>(kept->size()),
                                      b + static_cast<Eigen::Index>(after.size()));
    for (std::size_t k = 0; k < after.size(); ++k) {
      for (std::size_t i = 0; i < kept->size(); ++i)
        q.base.columns(static_cast<Eigen::Index>(i), b + static_cast<Eigen::Index>(k)) =
            stands_off(p, after[k], static_cast<std::size_t>((*kept)[i])) ? 1.0 : 0.0;
      q.base.names.push_back("offset_after_set_aside_" + std::to_string(k + 1) + "_um");
    }
  }
  const auto crop = [kept](Variant& v, bool whole) {
    Eigen::MatrixXd cropped = v.block.columns(*kept, Eigen::all);
    if (whole) v.columns_all_samples = std::move(v.block.columns);
    v.block.columns = std::move(cropped);
  };
  for (auto& c : q.candidates) {
    for (auto& v : c.variants) crop(v, keep_whole);
    if (!c.generate) continue;
    c.generate = [generate = c.generate, kept, n, crop](const Eigen::VectorXd& r, const std::vector<bool>& use) {
      Eigen::VectorXd whole = Eigen::VectorXd::Zero(n);
      std::vector<bool> in_use(static_cast<std::size_t>(n), false);
      for (std::size_t i = 0; i < kept->size(); ++i) {
        whole[(*kept)[i]] = r[static_cast<Eigen::Index>(i)];
        in_use[static_cast<std::size_t>((*kept)[i])] = use[i];
      }
      std::vector<Variant> vs = generate(whole, in_use);
      for (auto& v : vs) crop(v, true);
      return vs;
    };
  }
  if (p.contribution_of) {
    std::vector<std::size_t> nearest(static_cast<std::size_t>(n));  // for each sample, the kept one standing in
    std::size_t k = 0;
    for (std::size_t i = 0; i < nearest.size(); ++i) {
      while (k + 1 < kept->size() && (static_cast<std::size_t>((*kept)[k]) < i ||
                                      p.samples[static_cast<std::size_t>((*kept)[k])].run < p.samples[i].run))
        ++k;
      nearest[i] = k;
    }
    q.contribution_of = [of = p.contribution_of, nearest = std::move(nearest)](const Eigen::VectorXd& term) {
      Eigen::VectorXd whole(static_cast<Eigen::Index>(nearest.size()));
      for (std::size_t i = 0; i < nearest.size(); ++i)
        whole[static_cast<Eigen::Index>(i)] = term[static_cast<Eigen::Index>(nearest[i])];
      return of(whole);
    };
  }
  return out;
}

// The localized places of a report's remaining structure, in the whole problem's samples (`index`: the
// whole problem's index of each sample of the problem the report is of).
// Where a pass left structure no effect explains, place by place, in the whole problem's samples
// (`index`: the whole problem's index of each sample of the pass's problem): the places of its remaining
// structure, or when that is structured throughout, those of the probe (Pass::probe).
std::vector<Location> remaining_places(const Pass& pass, const std::vector<Eigen::Index>& index, bool& from_probe) {
  std::vector<Location> places;
  for (const auto& m : pass.report.remaining) places.insert(places.end(), m.locations.begin(), m.locations.end());
  from_probe = places.empty();
  if (from_probe) places = pass.probe;
  for (Location& l : places) {
    l.first_sample = static_cast<std::size_t>(index[l.first_sample]);
    l.end_sample = static_cast<std::size_t>(index[l.end_sample - 1]) + 1;
  }
  return places;
}

// The samples [from, to) a place sets aside: the place and a margin on either side (its own length, at most
// 1/32 of its run: the tails of a step or a ring-down beyond half its peak).
std::pair<std::size_t, std::size_t> stretch_of(const Problem& p,
                                               const std::vector<std::pair<std::size_t, std::size_t>>& ranges,
                                               const Location& l) {
  const auto [a, b] = ranges[p.samples[l.first_sample].run];
  const std::size_t len = l.end_sample - l.first_sample, margin = std::min(len, (b - a) / 32);
  return {l.first_sample - std::min(margin, l.first_sample - a), std::min(b, l.end_sample + margin)};
}

// Sets aside each place's stretch. Returns the samples set aside in all.
std::size_t set_aside(const Problem& p, const std::vector<Location>& places, std::vector<bool>& keep) {
  const auto ranges = run_ranges(p);
  for (const auto& l : places) {
    const auto [from, to] = stretch_of(p, ranges, l);
    for (std::size_t i = from; i < to; ++i) keep[i] = false;
  }
  return static_cast<std::size_t>(std::count(keep.begin(), keep.end(), false));
}

// A place's run and the first sample after the stretch set aside about it (or its run's end): where the
// reading may stand off (without_samples).
std::pair<std::size_t, std::size_t> offset_after(const Problem& p, const Location& l, const std::vector<bool>& keep) {
  const std::size_t run = p.samples[l.first_sample].run;
  std::size_t i = l.end_sample;
  while (i < keep.size() && !keep[i] && p.samples[i].run == run) ++i;
  return {run, i};
}

// A run the structure tests could look at that setting aside would leave too short for them (a traverse's
// pass of 33 readings): its label, or "" when there is none.
std::string starved_run(const Problem& p, const std::vector<bool>& keep) {
  const auto ranges = run_ranges(p);
  for (std::size_t r = 0; r < ranges.size(); ++r) {
    const auto [a, b] = ranges[r];
    const auto kept = static_cast<std::size_t>(
        std::count(keep.begin() + static_cast<std::ptrdiff_t>(a), keep.begin() + static_cast<std::ptrdiff_t>(b), true));
    if (b - a >= min_run_samples && kept < min_run_samples) return p.runs[r].label;
  }
  return "";
}

// Of the places set aside, those the findings made without them do not explain. The last pass's model (the base,
// the reading's offsets after each place, the findings' terms), fitted to the samples kept, predicts every
// sample; a place whose stretch it predicts to within the noise (its residual's sum of squares against sigma^2
// times its samples, chi-square, Bonferroni over the places) was the structure of an effect found later (in the
// first pass, the backlash's lobes of the other run beside a slip), not a fault. All kept when the fit fails.
std::vector<bool> unexplained_places(const Problem& p, const Pass& pass, const std::vector<Location>& places,
                                     const std::vector<bool>& keep,
                                     const std::vector<std::pair<std::size_t, std::size_t>>& after, double sigma,
                                     double alpha) {
  std::vector<bool> out(places.size(), true);
  const auto n = static_cast<Eigen::Index>(p.samples.size());
  if (!(sigma > 0) || places.size() < 2) return out;
  Eigen::Index cols = p.base.columns.cols() + static_cast<Eigen::Index>(after.size());
  for (const TermColumns& t : pass.terms) {
    const Eigen::MatrixXd& c = t.generated ? t.all_samples : p.candidates[t.cand].variants[t.index].block.columns;
    if (c.rows() != n) return out;
    cols += c.cols();
  }
  Eigen::MatrixXd design(n, cols);
  Eigen::Index at = 0;
  design.leftCols(p.base.columns.cols()) = p.base.columns;
  at += p.base.columns.cols();
  for (const auto& a : after) {
    for (Eigen::Index i = 0; i < n; ++i) design(i, at) = stands_off(p, a, static_cast<std::size_t>(i)) ? 1.0 : 0.0;
    ++at;
  }
  for (const TermColumns& t : pass.terms) {
    const Eigen::MatrixXd& c = t.generated ? t.all_samples : p.candidates[t.cand].variants[t.index].block.columns;
    design.middleCols(at, c.cols()) = c;
    at += c.cols();
  }
  const Eigen::VectorXd y = observations(p);
  const auto rows = rows_in_use(keep);
  const LsqResult fit = solve_lsq(design(rows, Eigen::all), y(rows), Eigen::VectorXd(),
                                  std::vector<std::string>(static_cast<std::size_t>(cols)));
  if (!fit.ok) return out;
  const Eigen::VectorXd residual = y - design * fit.fitted;
  const auto ranges = run_ranges(p);
  for (std::size_t k = 0; k < places.size(); ++k) {
    const auto [from, to] = stretch_of(p, ranges, places[k]);
    const double chi2 =
        residual.segment(static_cast<Eigen::Index>(from), static_cast<Eigen::Index>(to - from)).squaredNorm() /
        (sigma * sigma);
    out[k] = chi2_sf(chi2, static_cast<double>(to - from)) * static_cast<double>(places.size()) < alpha;
  }
  return out;
}

// Places set aside in successive rounds that are one stretch of set-aside samples in a run (a ring-down's tail
// taken by the round after its peak's) are one place: merged, in the order the run passed them.
std::vector<Location> merge_contiguous(std::vector<Location> places, const std::vector<bool>& keep) {
  std::sort(places.begin(), places.end(),
            [](const Location& a, const Location& b) { return a.first_sample < b.first_sample; });
  std::vector<Location> out;
  for (Location& l : places) {
    if (!out.empty() && out.back().run == l.run) {
      Location& prev = out.back();
      const std::size_t from = std::min(prev.end_sample, l.first_sample);
      const std::size_t to = std::max(prev.end_sample, l.first_sample);
      if (std::none_of(keep.begin() + static_cast<std::ptrdiff_t>(from), keep.begin() + static_cast<std::ptrdiff_t>(to),
                       [](bool k) { return k; })) {
        if (l.end_sample > prev.end_sample) {
          prev.end_sample = l.end_sample;
          prev.where.second = l.where.second;
          prev.t_from_run_start_s.second = l.t_from_run_start_s.second;
          prev.t_machine_s.second = l.t_machine_s.second;
        }
        if (std::abs(l.peak_um) > std::abs(prev.peak_um)) prev.peak_um = l.peak_um;
        continue;
      }
    }
    out.push_back(std::move(l));
  }
  return out;
}

// Whether each place of what is left repeats in another run: judged among the places reported (those a
// partial fit's residual showed in other runs are not among them).
void repeats_among(std::vector<Mismatch>& remaining, const std::string& domain) {
  std::vector<Location*> all;
  for (auto& m : remaining)
    for (auto& l : m.locations) all.push_back(&l);
  double lo = 1e300, hi = -1e300;
  for (const Location* l : all) {
    lo = std::min({lo, l->where.first, l->where.second});
    hi = std::max({hi, l->where.first, l->where.second});
  }
  const double tol = domain == "angle_deg" ? 3.6 : 0.01 * std::max(0.0, hi - lo);
  for (Location* a : all) {
    a->repeats_in.clear();
    const auto [alo, ahi] = std::minmax(a->where.first, a->where.second);
    for (const Location* b : all) {
      if (b->run == a->run) continue;
      const auto [blo, bhi] = std::minmax(b->where.first, b->where.second);
      if (alo <= bhi + tol && blo <= ahi + tol &&
          std::find(a->repeats_in.begin(), a->repeats_in.end(), b->run) == a->repeats_in.end())
        a->repeats_in.push_back(b->run);
    }
  }
}

// One fault is one place: a place set aside with the others whose stretch the last pass's findings explain
// (unexplained_places) is given back, and the pass run again with the rest set aside. Kept only when that pass
// finds as much and leaves no new structure; `aside`, `keep`, `after` and `last` are then its.
void release_explained(const Problem& problem, const ExplainOptions& options, double sigma,
                       std::vector<Location>& aside, std::vector<bool>& keep,
                       std::vector<std::pair<std::size_t, std::size_t>>& after, Pass& last) {
  const std::vector<bool> fault = unexplained_places(problem, last, aside, keep, after, sigma, options.alpha);
  const auto faults = static_cast<std::size_t>(std::count(fault.begin(), fault.end(), true));
  if (faults == 0 || faults == aside.size()) return;
  std::vector<Location> places;
  for (std::size_t k = 0; k < aside.size(); ++k)
    if (fault[k]) places.push_back(aside[k]);
  std::vector<bool> trial(keep.size(), true);
  set_aside(problem, places, trial);
  std::vector<std::pair<std::size_t, std::size_t>> trial_after;
  for (const auto& l : places) trial_after.push_back(offset_after(problem, l, trial));
  const Reduced reduced = without_samples(problem, trial, trial_after, options.keep_columns);
  if (options.on_progress)
    options.on_progress("pass with " + std::to_string(places.size()) + " of " + std::to_string(aside.size()) +
                        " places set aside (the findings explain the others)");
  Pass next = explain_once(reduced.problem, options);
  if (next.report.findings.size() < last.report.findings.size() ||
      (next.report.unexplained && !last.report.unexplained))
    return;
  aside = std::move(places);
  keep = std::move(trial);
  after = std::move(trial_after);
  last = std::move(next);
}

}  // namespace

// When the residual left is structured at a few places no effect explains, the findings of the first
// pass may be partial fits of it or nothing at all (each real effect must remove most of the structure
// left without it, and the unexplained place is part of that structure). The places are set aside and the
// effects sought again in the rest: what is found there is reported with the places, `unexplained`.
Report explain(const Problem& problem, const ExplainOptions& options) {
  Pass first = explain_once(problem, options);
  const std::size_t n = problem.samples.size();
  std::vector<Eigen::Index> index(n);
  for (std::size_t i = 0; i < n; ++i) index[i] = static_cast<Eigen::Index>(i);
  std::vector<bool> keep(n, true);
  std::vector<Location> aside;
  std::vector<std::pair<std::size_t, std::size_t>> after;  // per place set aside: its run, the first sample after it
  std::optional<Pass> later;
  std::string starved;  // why the places were not set aside (a run would become too short to test)
  // Every place of a residual structured locally; of the probe (Pass::probe) only the strongest a round:
  // its other places may be the partial fits' leftovers, which the effects found without it explain.
  for (int round = 0; round < 3 && options.max_set_aside > 0; ++round) {
    const Pass& cur = later ? *later : first;
    if (!cur.report.unexplained) break;
    bool from_probe = false;
    std::vector<Location> places = remaining_places(cur, index, from_probe);
    if (places.empty()) break;
    if (from_probe)
      places = {*std::max_element(places.begin(), places.end(), [](const Location& a, const Location& b) {
        return std::abs(a.peak_um) < std::abs(b.peak_um);
      })};
    std::vector<bool> trial = keep;
    const std::size_t count = set_aside(problem, places, trial);
    if (static_cast<double>(count) > options.max_set_aside * static_cast<double>(n)) break;
    if (const std::string run = starved_run(problem, trial); !run.empty()) {
      starved = "the places no effect explains were not set aside: " + run + " would keep fewer than " +
                std::to_string(min_run_samples) + " samples, too few for the structure tests";
      break;
    }
    auto trial_after = after;
    for (const auto& l : places) trial_after.push_back(offset_after(problem, l, trial));
    Reduced reduced = without_samples(problem, trial, trial_after, options.keep_columns);
    if (options.on_progress)
      options.on_progress("pass " + std::to_string(round + 2) + ", " + std::to_string(aside.size() + places.size()) +
                          " places set aside");
    Pass next = explain_once(reduced.problem, options);
    keep = std::move(trial);
    after = std::move(trial_after);
    index = std::move(reduced.kept);
    for (auto& l : places) l.set_aside = true;
    aside.insert(aside.end(), places.begin(), places.end());
    later = std::move(next);
  }
  if (!later) {
    if (!starved.empty()) first.report.notes.push_back(starved);
    return std::move(first.report);
  }
  release_explained(problem, options, first.report.noise_um, aside, keep, after, *later);
  Report out = std::move(later->report);
  out.n = first.report.n;
  out.set_aside = static_cast<std::size_t>(std::count(keep.begin(), keep.end(), false));
  out.noise_um = first.report.noise_um;
  out.mismatch = first.report.mismatch;
  aside = merge_contiguous(std::move(aside), keep);
  Mismatch m;
  m.domain = problem.domain;
  m.band = "-";
  m.evidence =
      "no effect of the library explains it: set aside, the findings are fitted to the rest, with the reading free "
      "to stand off by a constant after each place (a nuisance for a step, not a finding)";
  for (const auto& l : aside) {
    m.where += (m.where.empty() ? "" : ", ") + l.run + " " + printf_number("%.4g", l.where.first) + ".." +
               printf_number("%.4g", l.where.second) + (problem.domain == "angle_deg" ? " deg" : " mm");
    m.ranges.emplace_back(std::min(l.where.first, l.where.second), std::max(l.where.first, l.where.second));
  }
  m.locations = aside;
  out.remaining.insert(out.remaining.begin(), std::move(m));
  repeats_among(out.remaining, problem.domain);
  out.unexplained = true;
  out.notes.push_back(
      std::to_string(out.set_aside) + " of " + std::to_string(n) + " samples (" +
      printf_number("%.1f", 100.0 * static_cast<double>(out.set_aside) / static_cast<double>(n)) + " %) at " +
      std::to_string(aside.size()) +
      " places no effect explains were set aside; the baseline, findings and final fit are of the rest");
  return out;
}

std::vector<Eigen::Index> rows_in_use(const std::vector<bool>& use) {
  std::vector<Eigen::Index> rows;
  for (std::size_t i = 0; i < use.size(); ++i)
    if (use[i]) rows.push_back(static_cast<Eigen::Index>(i));
  return rows;
}

Eigen::VectorXd base_prediction(const Block& base, const Eigen::VectorXd& y_um, const std::vector<bool>& use) {
  const auto rows = rows_in_use(use);
  const LsqResult fit = solve_lsq(base.columns(rows, Eigen::all), y_um(rows), Eigen::VectorXd(), base.names);
  if (!fit.ok) return {};
  return base.columns * fit.fitted;
}

Variant sensor_nonlinearity_variant(const std::vector<double>& reading_um) {
  double mean = 0;
  for (double v : reading_um) mean += v;
  mean /= static_cast<double>(reading_um.size());
  Variant v;
  v.block.names = {results::name(results::sensor_quadratic), results::name(results::sensor_cubic)};
  v.block.columns.resize(static_cast<Eigen::Index>(reading_um.size()), 2);
  for (std::size_t i = 0; i < reading_um.size(); ++i) {
    const double d = reading_um[i] - mean;
    v.block.columns(static_cast<Eigen::Index>(i), 0) = d * d;
    v.block.columns(static_cast<Eigen::Index>(i), 1) = d * d * d;
  }
  return v;
}

std::function<std::vector<Variant>(const Eigen::VectorXd&, const std::vector<bool>&)> sensor_nonlinearity_generator(
    const Block& base, const Eigen::VectorXd& y_um, std::vector<double> offset_um) {
  if (static_cast<std::size_t>(base.columns.rows()) != static_cast<std::size_t>(y_um.size()) ||
      (!offset_um.empty() && offset_um.size() != static_cast<std::size_t>(y_um.size())))
    throw std::invalid_argument("explain: sensor_nonlinearity: base, samples and offsets differ in length");
  auto data =
      std::make_shared<const std::tuple<Block, Eigen::VectorXd, std::vector<double>>>(base, y_um, std::move(offset_um));
  return [data](const Eigen::VectorXd&, const std::vector<bool>& use) {
    const auto& [b, y, offset] = *data;
    if (use.size() != static_cast<std::size_t>(y.size()))
      throw std::invalid_argument("explain: sensor_nonlinearity: the row mask and the samples differ in length");
    const Eigen::VectorXd predicted = base_prediction(b, y, use);
    if (predicted.size() == 0) return std::vector<Variant>{};
    std::vector<double> reading(static_cast<std::size_t>(y.size()));
    for (std::size_t i = 0; i < reading.size(); ++i) {
      const auto r = static_cast<Eigen::Index>(i);
      reading[i] = (use[i] ? y[r] - (y[r] - predicted[r]) : predicted[r]) + (offset.empty() ? 0.0 : offset[i]);
    }
    return std::vector<Variant>{sensor_nonlinearity_variant(reading)};
  };
}

std::vector<ParamValue> amp_phase(const std::string& amp_name, const std::string& phase_name, const Eigen::VectorXd& x,
                                  const Eigen::MatrixXd& cov) {
  const AmplitudePhase ap = amplitude_phase(x[0], x[1], cov(0, 0), cov(1, 1), cov(0, 1));
  constexpr double deg = 180 / std::numbers::pi;
  return {{amp_name, ap.amplitude, ap.u_amplitude}, {phase_name, ap.phase_rad * deg, ap.u_phase_rad * deg}};
}

}  // namespace guideway::models::explain
