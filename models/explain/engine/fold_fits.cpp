// The held-out evaluation of EXPLAIN's selection (fold_fits.hpp).
#include "models/explain/engine/fold_fits.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "models/explain/engine/subspace.hpp"

namespace guideway::models::explain::engine {

namespace {

// Whether v is one of the candidate's listed variants (not of a generated list).
bool is_listed(const Candidate& c, const Variant* v) {
  return !c.variants.empty() && v >= c.variants.data() && v < c.variants.data() + c.variants.size();
}

}  // namespace

FoldFits::FoldFits(const Problem& problem, const ExplainOptions& options, const Eigen::VectorXd& y,
                   const GroupedBase& base, std::vector<FoldRows> folds, std::vector<double>& choose_buffer,
                   std::size_t cache_bytes)
    : p_(problem),
      o_(options),
      y_(y),
      base_(base),
      n_(static_cast<std::size_t>(y.size())),
      folds_(std::move(folds)),
      choose_buffer_(choose_buffer),
      cache_bytes_(cache_bytes) {}

HeldOut FoldFits::heldout(const std::vector<Term>& terms, std::size_t skip, std::size_t trial,
                          const Variant* fixed) const {
  HeldOut out;
  Eigen::Index columns = p_.base.columns.cols();
  for (std::size_t k = 0; k < terms.size(); ++k)
    if (k != skip) columns += width(variant_of(p_, terms[k]));
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
    if (trial != none) {
      if (o_.heldout_reselect) {
        out.trial[f] = chosen_in_fold(f, trial, terms, skip);
        if (!out.trial[f].variant)
          return fail(p_.candidates[trial].effect + " has no variant that can be fitted on the training rows");
      } else {
        out.trial[f] = fold_block(*fixed, is_listed(p_.candidates[trial], fixed));
      }
    }
    const Eigen::MatrixXd rest = fold_columns(f, terms, skip, trial != none ? out.trial[f].variant.get() : nullptr);
    const auto cols = static_cast<std::size_t>(p_.base.columns.cols() + rest.cols());  // as the design has them
    if (fold.train_rows() < cols + 2)
      return fail(std::to_string(fold.train_rows()) + " training rows for " + std::to_string(cols) + " columns");
    Eigen::VectorXd predicted;
    if (!predict_fold(f, rest, predicted)) return fail("the fit failed (not finite)");
    sse += (y_(fold.test) - predicted).squaredNorm();
    count += fold.test.size();
  }
  out.rms = count ? std::sqrt(sse / static_cast<double>(count)) : nan;
  return out;
}

// The fit of [B R y] on the training rows from the base's factor there, Q_S = blockdiag(Q_g) W (grouped_base.hpp):
// [B R y] = [Q_S E'] [[R_B C] [0 R_E]] with C = Q_S^T [R y] and E = [R y] - Q_S C = E' R_E, so only E is factored
// (tall_r); the projection is done twice (classical Gram-Schmidt loses orthogonality to Q_S where a column lies
// near the base's span). The minimum-norm solution of the column-scaled problem (min_norm_solution): with columns
// the training rows cannot separate (Lai's unidentifiable terms) a basic solution's held-out prediction would
// depend on which column round-off pivots out. A fold too short to be reduced first, or a problem without a base,
// is fitted on its training rows directly (predict()).
bool FoldFits::predict_fold(std::size_t f, const Eigen::MatrixXd& rest, Eigen::VectorXd& predicted) const {
  const FoldRows& fold = folds_[f];
  const Eigen::Index p = base_.cols(), pr = rest.cols();
  Eigen::MatrixXd jh(static_cast<Eigen::Index>(fold.test.size()), p + pr);
  if (p > 0) jh.leftCols(p) = p_.base.columns(fold.test, base_.columns());
  if (pr > 0) jh.rightCols(pr) = rest(fold.test, Eigen::all);
  const GroupedBase::Span& s = base_.span(f);
  if (p > 0 && s.rows >= 2 * (p + pr + 1)) {
    Eigen::MatrixXd e(static_cast<Eigen::Index>(n_), pr + 1);
    e.leftCols(pr) = rest;
    e.col(pr) = y_;
    zero_rows(base_.ranges(f), e);
    Eigen::VectorXd scale(p + pr);
    scale << s.scale, scale_columns(e.leftCols(pr));
    Eigen::MatrixXd c = s.w.transpose() * base_.products(s, e);
    base_.subtract(s, s.w * c, e);
    const Eigen::MatrixXd again = s.w.transpose() * base_.products(s, e);
    base_.subtract(s, s.w * again, e);
    c += again;
    Eigen::MatrixXd r = Eigen::MatrixXd::Zero(p + pr + 1, p + pr + 1);
    r.topLeftCorner(p, p) = s.r;
    r.topRightCorner(p, pr + 1) = c;
    r.bottomRightCorner(pr + 1, pr + 1) = tall_r(e);
    const Eigen::VectorXd b = min_norm_solution(r, p + pr);
    if (!b.allFinite()) return false;
    predicted = jh * (scale.asDiagonal() * b);
    return true;
  }
  const std::vector<Eigen::Index> train = rows_in_use(fold.use);
  Eigen::MatrixXd jt(static_cast<Eigen::Index>(train.size()), p + pr);
  if (p > 0) jt.leftCols(p) = p_.base.columns(train, base_.columns());
  if (pr > 0) jt.rightCols(pr) = rest(train, Eigen::all);
  return predict(std::move(jt), y_(train), jh, predicted);
}

void FoldFits::refold(std::vector<Term>& terms, std::size_t k) const {
  Term& t = terms[k];
  const Variant& now = variant_of(p_, t);
  for (std::size_t f = 0; f < folds_.size(); ++f) {
    if (folds_[f].test.empty()) continue;
    if (!o_.heldout_reselect) {
      t.folds[f] = fold_block(now, t.pool == nullptr);
      continue;
    }
    FoldBlock b = chosen_in_fold(f, t.cand, terms, k);
    if (!b.variant) continue;  // the fold keeps its earlier choice, made on its training rows too
    t.folds[f] = std::move(b);
  }
}

FoldBlock FoldFits::chosen_in_fold(std::size_t f, std::size_t cand, const std::vector<Term>& terms,
                                   std::size_t skip) const {
  const Candidate& c = p_.candidates[cand];
  const Model& m = fold_model(f, terms, skip);
  const auto pool = generated(c, m.residual, folds_[f].use, n_);
  const auto& variants = listed(c, pool);
  const Choice ch = choose(variants, allowed(p_, cand, variants, terms, skip), m, choose_buffer_);
  if (ch.index == none) return {};
  return fold_block(variants[ch.index], pool == nullptr);
}

// Kept by the columns' ids (a term's fold columns depend on when they were chosen, not only on its variant):
// every trial of a forward step and every re-choice is fitted against the same fold models.
const Model& FoldFits::fold_model(std::size_t f, const std::vector<Term>& terms, std::size_t skip) const {
  std::vector<std::uint64_t> key{f};
  for (std::size_t k = 0; k < terms.size(); ++k)
    if (k != skip) key.push_back(terms[k].folds[f].id);
  std::sort(key.begin() + 1, key.end());
  if (std::find(key.begin() + 1, key.end(), 0) == key.end())
    if (const auto it = fold_models_.find(key); it != fold_models_.end()) return it->second;
  Model m = model_of(base_, f, fold_columns(f, terms, skip), 0, y_);
  const std::size_t bytes = m.bytes();
  if (fold_model_bytes_ + bytes > cache_bytes_) {
    fold_models_.clear();
    fold_model_bytes_ = 0;
  }
  fold_model_bytes_ += bytes;
  return fold_models_.insert_or_assign(std::move(key), std::move(m)).first->second;
}

Eigen::MatrixXd FoldFits::fold_columns(std::size_t f, const std::vector<Term>& terms, std::size_t skip,
                                       const Variant* extra) const {
  Eigen::Index cols = extra ? width(*extra) : 0;
  for (std::size_t k = 0; k < terms.size(); ++k)
    if (k != skip) cols += width(*terms[k].folds[f].variant);
  Eigen::MatrixXd j(static_cast<Eigen::Index>(n_), cols);
  Eigen::Index at = 0;
  for (std::size_t k = 0; k < terms.size(); ++k) {
    if (k == skip) continue;
    const Variant& v = *terms[k].folds[f].variant;
    write_columns(v, j.middleCols(at, width(v)));
    at += width(v);
  }
  if (extra) write_columns(*extra, j.rightCols(width(*extra)));
  return j;
}

}  // namespace guideway::models::explain::engine
