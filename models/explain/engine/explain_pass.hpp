#pragma once
// One pass of EXPLAIN over a problem (models/explain/engine, docs/explain.md steps 1-4): the base fitted and its
// residual located, the effects selected, the findings reported with their parameters, shares and residual
// curves, and the verdict on what is left. explain() runs passes again with places set aside (set_aside.hpp).
// Pure functions; thread safe.

#include <cstddef>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

// What is explained, one value per sample; refuses too few samples, a base of the wrong size, non-finite
// samples and candidates of the wrong size.
Eigen::VectorXd observations(const Problem& problem);

// A finding's term as the whole problem sees it: its candidate and variant, and a generated variant's columns
// over every sample of the problem given to explain() (a listed variant's are that problem's own).
struct TermColumns {
  std::size_t cand = 0, index = 0;
  bool generated = false;
  Eigen::MatrixXd all_samples;
  std::size_t searched = 0;  // its variant's nonlinear parameters searched (counted in the BIC)
};

// The columns of `terms` over every sample of the problem (a generated term's its own, a listed term's its variant's,
// made in `scratch` where made on demand); empty where one has another number of rows than n.
std::vector<const Eigen::MatrixXd*> columns_of_terms(const Problem& problem, const std::vector<TermColumns>& terms,
                                                     Eigen::Index n, std::vector<Eigen::MatrixXd>& scratch);

struct Pass {
  Report report;
  // Where the residual of the effects held before the share rule dropped any is structured, place by
  // place (empty: none dropped, or structured throughout).
  std::vector<Location> probe;
  std::vector<TermColumns> terms;  // the findings' terms, in the order taken
  // The terms of the effects held before the share rule dropped any, where the pass ends `unexplained` (the probe's):
  // partial fits of a fault beside real effects (engine/level_step.hpp winning_step looks for a step beside them).
  std::vector<TermColumns> probe_terms;
};

// Where a pass's residual is structured at places no effect explains, whether explain() would set them aside (the
// places in the pass's problem's samples): true, and a pass whose share rule has dropped every effect it took ends
// there (docs/explain.md step 5: what it could take next are more partial fits of the same structure).
using SetAsideCheck = std::function<bool(const std::vector<Location>& places)>;

Pass explain_once(const Problem& problem, const ExplainOptions& options, const SetAsideCheck& can_set_aside = {});

}  // namespace guideway::models::explain::engine
