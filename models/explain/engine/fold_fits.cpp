// The held-out evaluation of EXPLAIN's selection (fold_fits.hpp).
#include "models/explain/engine/fold_fits.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "models/explain/engine/variant_set_cache.hpp"

namespace guideway::models::explain::engine {

FoldFits::FoldFits(const Problem& problem, const ExplainOptions& options, const Eigen::VectorXd& y,
                   std::vector<FoldRows> folds, std::vector<double>& choose_buffer)
    : p_(problem),
      o_(options),
      y_(y),
      n_(static_cast<std::size_t>(y.size())),
      folds_(std::move(folds)),
      choose_buffer_(choose_buffer) {
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

HeldOut FoldFits::heldout(const std::vector<Term>& terms, std::size_t skip, std::size_t trial,
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
    if (trial != none) {
      const Variant* chosen = fixed;
      FoldChoice fc;
      if (o_.heldout_reselect) {
        fc = chosen_in_fold(f, trial, terms, skip);
        if (!fc.variant)
          return fail(p_.candidates[trial].effect + " has no variant that can be fitted on the training rows");
        chosen = fc.variant;
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
    const Eigen::VectorXd& yt = y_train_[f];
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

void FoldFits::refold(std::vector<Term>& terms, std::size_t k) const {
  Term& t = terms[k];
  const Variant& now = variant_of(p_, t);
  for (std::size_t f = 0; f < folds_.size(); ++f) {
    const FoldRows& fold = folds_[f];
    if (fold.test.empty()) continue;
    if (!o_.heldout_reselect) {
      t.folds[f] = fold_block(now, fold);
      continue;
    }
    const FoldChoice fc = chosen_in_fold(f, t.cand, terms, k);
    if (!fc.variant) continue;  // the fold keeps its earlier choice, made on its training rows too
    t.folds[f] = fold_block(*fc.variant, fold);
  }
}

FoldFits::FoldChoice FoldFits::chosen_in_fold(std::size_t f, std::size_t cand, const std::vector<Term>& terms,
                                              std::size_t skip) const {
  const FoldRows& fold = folds_[f];
  const Candidate& c = p_.candidates[cand];
  const Model& m = fold_model(f, terms, skip);
  Eigen::VectorXd r = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n_));
  r(fold.train) = m.residual;
  FoldChoice out;
  out.pool = generated(c, r, fold.use, n_);
  const auto& variants = listed(c, out.pool);
  const Choice ch = choose(variants, allowed(p_, cand, variants, terms, skip), &fold.train, m, choose_buffer_);
  if (ch.index != none) out.variant = &variants[ch.index];
  return out;
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
  Model m = model_of(fold_columns(f, terms, skip, true), 0, y_train_[f]);
  const std::size_t bytes = static_cast<std::size_t>(m.q.size() + m.residual.size()) * sizeof(double);
  if (fold_model_bytes_ + bytes > cache_budget_bytes) {
    fold_models_.clear();
    fold_model_bytes_ = 0;
  }
  fold_model_bytes_ += bytes;
  return fold_models_.insert_or_assign(std::move(key), std::move(m)).first->second;
}

// Kept within the memory budget; null at the fold's first held-out fit (factoring the base and forming its Q
// costs two plain fits: a problem whose base alone is tested, a null, never fits a fold twice).
std::shared_ptr<const FoldBase> FoldFits::fold_base_of(std::size_t f) const {
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

Eigen::MatrixXd FoldFits::fold_columns(std::size_t f, const std::vector<Term>& terms, std::size_t skip, bool train,
                                       const Eigen::MatrixXd* extra, bool with_base) const {
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

}  // namespace guideway::models::explain::engine
