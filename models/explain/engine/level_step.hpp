#pragma once
// A step in one run's level (a ball that slips in its cup and stays slipped for the rest of the run): the rival a
// first pass's findings are judged against (docs/explain.md step 5, issue 41 item 10). The library has no effect
// for it, so when the first pass ends with nothing structured left, effects that only took the run's level and the
// step (a thermal drift, a servo lag, a lateral play beside a reseated slip) would keep their shares. Pure
// functions; thread safe.

#include <cstddef>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "models/explain/engine/explain_pass.hpp"
#include "models/explain/engine/set_aside.hpp"
#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

// The strongest step within a run's level that the base leaves in the residual (the base and every run's own level
// fitted with it: a step near a run's start is otherwise one run's level against another's; 1/32 of each run at
// either end not searched): its place, the samples where a step
// fits within the chi-square(1) quantile at alpha of the best (a likelihood-ratio interval of where it is), its
// peak the step's size. None when the best step's chi-square against sigma_um^2 is not significant at alpha,
// Bonferroni over the samples searched, or the problem's stations' means are fitted out (a step is then not one
// column).
struct LevelStep {
  Location place;
  std::size_t run = 0, at = 0;  // the run, and its first sample after the best step
};
std::optional<LevelStep> level_step(const Problem& problem, double sigma_um, double alpha);

// Whether explaining the problem again with the step could beat the first pass by the BIC (with ln n for the step's
// sample searched), judged without a search: the base with the step's nuisance columns (`offsets`, fitted_offsets' of
// the step; no copy of the problem is made), beside each subset of the first pass's own findings refitted (their variants as chosen, their searched
// values counted), against the first pass's final BIC. No generator runs. False when none of those models could win:
// the step then only stands for what the findings already explain (a square wave's level, a drift's slope). Where
// the first pass took more than step_check_max_terms findings, true (the subsets are not all tried). The rival pass may
// still take effects the first did not; this asks only whether the step could replace the first pass's own.
inline constexpr std::size_t step_check_max_terms = 8;
bool step_could_win(const Problem& problem, const std::vector<OffsetAfter>& offsets, const Pass& first);

// The step in a run's level, sought beside the base, every run's level and each subset of `terms` (a first pass's
// findings, or the effects it held before its share rule dropped one: Pass::probe_terms), that fits best by the BIC
// (the step's sample counted as one value searched, the terms' searched values counted), when that comes below `bic`
// by more than ln n; each subset's step significant as level_step's. Beside the base alone the strongest step may be
// one a real effect makes (a backlash's reversal, a step in each run's level that the base does not fit), standing
// above a slip's beside it; beside the backlash the slip's stands out. None where there are more than
// step_check_max_terms terms. With the residual of that model (the base, the levels, the subset and the step), which
// says whether the step and those terms leave anything structured.
struct WinningStep {
  LevelStep step;
  Eigen::VectorXd residual_um;
};
std::optional<WinningStep> winning_step(const Problem& problem, double sigma_um, double alpha,
                                        const std::vector<TermColumns>& terms, double bic);

}  // namespace guideway::models::explain::engine
