#pragma once
// The held-out evaluation of EXPLAIN's selection (models/explain/engine, docs/explain.md "Held out"): every
// fold's held-out rows predicted from a fit to its training rows of the base, the terms (each with the variant
// chosen on that fold's training rows) and a trial candidate. A fold's training rows are every group of the
// grouped base but its own (grouped_base.hpp): the base is factored once for every fold. The fold models are kept
// within a memory budget. Not thread safe: one per selection.

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "models/explain/engine/folds.hpp"
#include "models/explain/engine/grouped_base.hpp"
#include "models/explain/engine/model_fit.hpp"
#include "models/explain/engine/terms.hpp"
#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

class FoldFits {
 public:
  // `base`: the problem's base grouped by fold (group f = fold f's held-out rows). `choose_buffer`: choose()'s
  // batches, shared with the selection (one n x 64 buffer). `cache_bytes`: what the fold models may hold.
  FoldFits(const Problem& problem, const ExplainOptions& options, const Eigen::VectorXd& y, const GroupedBase& base,
           std::vector<FoldRows> folds, std::vector<double>& choose_buffer, std::size_t cache_bytes);

  // Held-out RMS of the base, the terms (but `skip`) and candidate `trial` (none: no trial). With
  // ExplainOptions::heldout_reselect (the default) the trial's variant is chosen again in each fold from the
  // training rows alone, as every term's was -- a generator gets the training residual, zero on the held-out
  // rows, and the mask of the training rows; otherwise the variant chosen on all the data (`fixed`) is taken
  // and only the coefficients are refitted, which is optimistic (the held-out rows took part in the choice;
  // bench/explain_heldout_bench.cpp). A fold that cannot be fitted makes it NaN.
  [[nodiscard]] HeldOut heldout(const std::vector<Term>& terms, std::size_t skip, std::size_t trial,
                                const Variant* fixed) const;

  // Term k's columns in every fold: its variant chosen again on the fold's training rows
  // (ExplainOptions::heldout_reselect), else the one chosen on all the data.
  void refold(std::vector<Term>& terms, std::size_t k) const;

  [[nodiscard]] std::size_t folds() const { return folds_.size(); }
  // The fold models kept dropped (made again when asked for: the same numbers).
  void drop_models() const {
    fold_models_.clear();
    fold_model_bytes_ = 0;
  }

 private:
  // Candidate `cand`'s variant chosen on fold f's training rows against the model of the terms (but `skip`)
  // there: the block of its columns, no variant when none can be fitted.
  [[nodiscard]] FoldBlock chosen_in_fold(std::size_t f, std::size_t cand, const std::vector<Term>& terms,
                                         std::size_t skip) const;
  // The model of the base and the terms (but `skip`) on fold f's training rows, kept by the columns' ids.
  [[nodiscard]] const Model& fold_model(std::size_t f, const std::vector<Term>& terms, std::size_t skip) const;
  // The terms' (but `skip`) columns in fold f and `extra`'s (a trial's) after them, every row.
  [[nodiscard]] Eigen::MatrixXd fold_columns(std::size_t f, const std::vector<Term>& terms, std::size_t skip,
                                             const Variant* extra = nullptr) const;
  // Fold f's held-out rows predicted from the fit of the base and `rest` (every row) to its training rows; false
  // when the fit is not finite.
  bool predict_fold(std::size_t f, const Eigen::MatrixXd& rest, Eigen::VectorXd& predicted) const;

  const Problem& p_;
  const ExplainOptions& o_;
  const Eigen::VectorXd& y_;
  const GroupedBase& base_;
  std::size_t n_;
  std::vector<FoldRows> folds_;
  std::vector<double>& choose_buffer_;
  std::size_t cache_bytes_;

  mutable std::map<std::vector<std::uint64_t>, Model> fold_models_;
  mutable std::size_t fold_model_bytes_ = 0;
};

}  // namespace guideway::models::explain::engine
