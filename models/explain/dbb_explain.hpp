#pragma once
// EXPLAIN for DBB runs. Base: Lai's geometric guideway terms (models/dbb: centre offset, scale,
// squareness, straightness and angular polynomials; shared by all runs, as the fixed socket is not
// moved). Candidates: every effect of the library with a DBB term (models/explain/effects/; docs/explain.md,
// docs/conventions.md for the signs). Runs are placed on one machine-time axis when every run has the metadata key
// `start_time_s` (machine time of its first sample); otherwise each run's drift has its own offset.
//
// The daemon's entry point is explain_dbb(): runs in, the explanation out (the EXPLAIN message's body).
// Pure functions; thread safe; throw std::invalid_argument / dbb::RunFormatError for unusable input.

#include <string>
#include <vector>

#include "formats/dbb_run.hpp"
#include "models/explain/explanation.hpp"

namespace guideway::models::explain {

struct Problem;  // explain.hpp (the engine, with Eigen): only for who builds or inspects problems

// Base + candidates for `guideway explain --model dbb`.
Problem dbb_problem(const std::vector<formats::DbbRun>& runs);
Report explain_dbb_report(const std::vector<formats::DbbRun>& runs, const ExplainOptions& options = {});
// The report as the explanation a session publishes (explanation_of).
results::Explanation explain_dbb(const std::vector<formats::DbbRun>& runs, const ExplainOptions& options = {});

// A given simulation against a recording (same sample grid: equal length, equal angles within 1e-6
// deg): the difference measured - simulated is explained with the same candidates and no base refit.
Problem dbb_compare_problem(const formats::DbbRun& simulated, const formats::DbbRun& measured);
Report explain_dbb_difference(const formats::DbbRun& simulated, const formats::DbbRun& measured,
                              const ExplainOptions& options = {});

}  // namespace guideway::models::explain
