#pragma once
// The models EXPLAIN's selection compares (models/explain/engine, docs/explain.md "Name and fit"): the base and
// a set of terms fitted on all the data and on every fold's training rows, a candidate tried against them, and
// earlier choices re-decided once a later effect has joined. Models and held-out figures of one set of terms
// are computed once and kept (variant_set_cache.hpp). Not thread safe: one per pass of explain().

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "models/common/least_squares.hpp"
#include "models/explain/engine/fold_fits.hpp"
#include "models/explain/engine/folds.hpp"
#include "models/explain/engine/model_fit.hpp"
#include "models/explain/engine/terms.hpp"
#include "models/explain/engine/variant_set_cache.hpp"
#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

class Selection {
 public:
  // The held-out folds: scheme.fold_of, the groups of the grouped base.
  Selection(const Problem& problem, const ExplainOptions& options, const Eigen::VectorXd& y,
            const HeldOutScheme& scheme);

  [[nodiscard]] const Problem& problem() const { return p_; }
  [[nodiscard]] const ExplainOptions& options() const { return o_; }
  [[nodiscard]] const Eigen::VectorXd& observations() const { return y_; }

  // The least-squares fit (solve_lsq) of the base and the terms on all the data: the base's columns read where the
  // problem holds them, beside the terms' made for it, never copied into one n x p design (the findings' fits
  // come when a pass is at its largest: bench/README.md "EXPLAIN's footprint").
  [[nodiscard]] LsqResult fit(const std::vector<Term>& terms) const;
  // The terms' columns alone (but `skip`'s).
  [[nodiscard]] Eigen::MatrixXd term_columns(const std::vector<Term>& terms, std::size_t skip = none) const;
  // The names of the base's columns and the terms'.
  [[nodiscard]] std::vector<std::string> names(const std::vector<Term>& terms) const;
  // The model of the base and the terms (but `skip`) on all the data.
  [[nodiscard]] Model model(const std::vector<Term>& terms, std::size_t skip = none) const;
  // Held-out RMS of the base, the terms (but `skip`) and candidate `trial` (FoldFits::heldout).
  // The models kept, on all the data and in the folds, dropped (made again when asked for: the same numbers); the
  // held-out figures stay.
  void drop_models() const {
    models_.clear();
    fits_.drop_models();
  }
  [[nodiscard]] HeldOut heldout(const std::vector<Term>& terms, std::size_t skip, std::size_t trial = none,
                                const Variant* fixed = nullptr) const;

  // Candidate c tried against the model `cur` of the terms: its best variant on all the data and the
  // F-test (Bonferroni over the grid points searched) and BIC against cur.
  [[nodiscard]] Trial trial(std::size_t c, const std::vector<Term>& terms, const Model& cur) const;

  // Term k's variant chosen again with the others in the model (on all the data and in every fold):
  // chosen before a later effect was taken, it may have absorbed part of that effect. True if it changed.
  bool rechoose(std::vector<Term>& terms, std::size_t k) const;
  // Terms i and j re-chosen together on all the data: every variant of i (generated against the model
  // without i) with j's best given it; the pair whose joint fit has the lowest BIC replaces theirs when that
  // is lower than now. True if the pair changed (then both are chosen again in every fold).
  bool rechoose_pair(std::vector<Term>& terms, std::size_t i, std::size_t j) const;

 private:
  const Problem& p_;
  const ExplainOptions& o_;
  const Eigen::VectorXd& y_;
  std::size_t n_;
  mutable std::vector<double> choose_buffer_;  // choose()'s batches
  GroupedBase base_;
  FoldFits fits_;
  mutable VariantSetCache<Model> models_;
  mutable VariantSetCache<HeldOut> heldouts_;
};

}  // namespace guideway::models::explain::engine
