#pragma once
// The held-out evaluation of EXPLAIN's selection (models/explain/engine, docs/explain.md "Held out"): every
// fold's held-out rows predicted from a fit to its training rows of the base, the terms (each with the variant
// chosen on that fold's training rows) and a trial candidate; the fold models and the folds' factored bases
// kept within a memory budget. Not thread safe: one per selection.

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "models/explain/engine/folds.hpp"
#include "models/explain/engine/model_fit.hpp"
#include "models/explain/engine/subspace.hpp"
#include "models/explain/engine/terms.hpp"
#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

class FoldFits {
 public:
  // `choose_buffer`: choose()'s batches, shared with the selection (one n x 64 buffer).
  FoldFits(const Problem& problem, const ExplainOptions& options, const Eigen::VectorXd& y, std::vector<FoldRows> folds,
           std::vector<double>& choose_buffer);

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

 private:
  // Candidate `cand`'s variant chosen on fold f's training rows against the model of the terms (but `skip`)
  // there; variant null when none can be fitted. The pool keeps a generated variant alive.
  struct FoldChoice {
    std::shared_ptr<const std::vector<Variant>> pool;
    const Variant* variant = nullptr;
  };
  [[nodiscard]] FoldChoice chosen_in_fold(std::size_t f, std::size_t cand, const std::vector<Term>& terms,
                                          std::size_t skip) const;
  // The model of the base and the terms (but `skip`) on fold f's training rows, kept by the columns' ids.
  [[nodiscard]] const Model& fold_model(std::size_t f, const std::vector<Term>& terms, std::size_t skip) const;
  // Fold f's base factored on its training rows; null without a base and at the fold's first held-out fit.
  [[nodiscard]] std::shared_ptr<const FoldBase> fold_base_of(std::size_t f) const;
  // Fold f's columns of the base (unless with_base is false) and the terms (but `skip`) on its training or
  // held-out rows, and `extra`'s (a trial's on the same rows) after them.
  [[nodiscard]] Eigen::MatrixXd fold_columns(std::size_t f, const std::vector<Term>& terms, std::size_t skip,
                                             bool train, const Eigen::MatrixXd* extra = nullptr,
                                             bool with_base = true) const;

  const Problem& p_;
  const ExplainOptions& o_;
  const Eigen::VectorXd& y_;
  std::size_t n_;
  std::vector<FoldRows> folds_;
  std::vector<double>& choose_buffer_;
  std::vector<Eigen::MatrixXd> base_train_, base_test_;
  std::vector<Eigen::VectorXd> y_train_;

  mutable std::map<std::vector<std::uint64_t>, Model> fold_models_;
  mutable std::size_t fold_model_bytes_ = 0;
  mutable std::vector<std::shared_ptr<const FoldBase>> fold_bases_;
  mutable std::vector<int> fold_fits_;  // held-out fits per fold so far
  mutable std::size_t fold_base_bytes_ = 0;
};

}  // namespace guideway::models::explain::engine
