#pragma once
// EXPLAIN's report as the explanation every layer above the models reads (results/explanation.hpp): what a
// session returns and publishes, what `guideway explain --json` prints. Built here, from the engine's report,
// so that what the report keeps for the models alone (the findings' columns, the samples a place spans) stays
// behind. Pure; thread safe.

#include "models/explain/explain_result.hpp"
#include "results/explanation.hpp"

namespace guideway::models::explain {

// The report's explanation; the places' locations and the residual curves rounded to 4 decimals (0.1 nm;
// 1e-4 deg or mm: what a plot needs), so that they stay compact.
results::Explanation explanation_of(const Report& report);

}  // namespace guideway::models::explain
