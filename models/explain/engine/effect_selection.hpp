#pragma once
// The set of effects EXPLAIN reports (models/explain/engine, docs/explain.md "Name and fit"): forward selection
// on the tests, each earlier choice re-decided and re-tested whenever an effect joins, then every effect's share
// of the structure left without it; what is dropped is not tried again. Not thread safe: one per pass.

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "models/explain/engine/model_fit.hpp"
#include "models/explain/engine/selection.hpp"
#include "models/explain/engine/terms.hpp"
#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

class EffectSelection {
 public:
  // From the base model `base` and its held-out figure; sigma the noise level, visible_floor the energy below
  // which nothing counts as visible structure.
  EffectSelection(const Problem& problem, const ExplainOptions& options, const Selection& sel, Model base,
                  HeldOut base_heldout, double sigma, double visible_floor);

  // Whether the pass may end with the base's residual (its places would be set aside): with `probe`, places of
  // the residual held before the share rule first dropped an effect may stand for the base's own.
  using Settled = std::function<bool(const Model& base, bool probe)>;
  // `settled`, when given, is asked whenever the share rule has dropped every effect taken (after the forward
  // steps, and on trial after each effect joins: partial_fits_only): true ends the selection there (the base's
  // residual is then what the pass leaves).
  void run(const Settled& settled = {});

  [[nodiscard]] const std::vector<Term>& terms() const { return terms_; }
  // The effects held when the share rule first dropped one (partial fits of a cause outside the library
  // among them): their residual shows such a cause where the base's is structured throughout.
  [[nodiscard]] const std::optional<std::vector<Term>>& before_share() const { return before_share_; }
  [[nodiscard]] const Model& model() const { return cur_; }
  [[nodiscard]] double heldout() const { return cur_heldout_; }
  // The latest verdict of every candidate without a term, lowest delta BIC first.
  [[nodiscard]] std::vector<Considered> considered() const;

 private:
  void refresh();
  [[nodiscard]] bool has_term(std::size_t c) const;
  void drop(std::size_t k, Considered why);
  void prune(const std::string& after);
  [[nodiscard]] std::vector<Trial> trials(std::vector<std::size_t>& unfittable) const;
  std::string forward_step();
  bool drop_partial_fits();
  bool partial_fits_only(const Settled& settled, bool end_there);

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

}  // namespace guideway::models::explain::engine
