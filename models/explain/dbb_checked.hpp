#pragma once
// The identification of DBB runs that the CLI (`identify dbb`, `compensate dbb`) and the live DBB session
// share: models/dbb's identify with what EXPLAIN finds on the same runs, and neither of its models holds,
// fitted beside their terms (a drift, a vibration, a stick-slip, a sensor's nonlinearity; for Lai's fit also
// the spikes, the lateral play and a cyclic error), so that it is not read as one of them: a 1 um/min drift
// along X read as -0.25 um of backlash. A term that still contradicts EXPLAIN's value of it beyond 3
// combined standard uncertainties is "not determined", with both values.
// Pure functions; thread safe.

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "formats/dbb_run.hpp"
#include "models/dbb/identify.hpp"
#include "models/explain/explanation.hpp"
#include "results/params.hpp"

namespace guideway::models::explain {

struct CheckedIdentification {
  dbb::Identification id;
  std::vector<dbb::Estimate> explain;  // EXPLAIN's findings' parameters with an uncertainty
  std::vector<std::string> beside;     // the effects fitted beside ("thermal_drift")
  std::vector<std::string> notes;      // what was fitted beside, what EXPLAIN found that was not, and why
  // The terms fitted beside as fitted, summed, one value per sample of all the runs in their order (um;
  // empty when none): what no table holds, and what a verification takes out of the runs' G to judge
  // tables by what they can correct.
  std::vector<double> beside_um;
  std::vector<dbb::BesideTerm> beside_terms;  // what was fitted beside, as identify took it
  // EXPLAIN's explanation of the runs as `guideway explain --model dbb --json` gives it (none when EXPLAIN
  // could not run, or for identify_checked_like): a session publishes it without running EXPLAIN again.
  std::optional<results::Explanation> explanation;
};

// The note of CheckedIdentification::notes that lists what was fitted beside starts with this.
inline constexpr std::string_view fitted_beside_note = "fitted beside the terms";

// Runs EXPLAIN refuses (shorter than it needs, a gap too wide) are identified by the models alone, with a
// note that says why; what identify itself refuses throws as identify does.
// `explain`: EXPLAIN's options (its findings' columns are always kept: keep_columns).
CheckedIdentification identify_checked(const std::vector<formats::DbbRun>& runs,
                                       const dbb::IdentifyOptions& options = {}, const ExplainOptions& explain = {});
// How many times identify_checked has run in this process (each runs EXPLAIN: seconds of CPU on long runs):
// what a test counts to show that a session's end identifies once, its report included.
std::size_t identify_checked_count();
// The same for runs on the sample grid of `earlier_runs` (the same runs, angles and times: a retrace of runs
// simulated from the same machine file, or a retrace after a retrace): `earlier`'s terms are fitted beside
// again, without running EXPLAIN (its columns are the same); on another grid, identify_checked(runs).
CheckedIdentification identify_checked_like(const std::vector<formats::DbbRun>& runs,
                                            const CheckedIdentification& earlier,
                                            const std::vector<formats::DbbRun>& earlier_runs);

// How `term` contradicts another identification of the same runs (`others`, EXPLAIN's findings: the estimate
// of the same name): their difference beyond 3 combined standard uncertainties, in words with both values and
// how far apart they are; "" when it does not (no such estimate, or either has no u).
std::string contradiction(const dbb::Estimate& term, const std::vector<dbb::Estimate>& others);

// The identification as PARAMS' body (models/dbb to_params) with a term that contradicts EXPLAIN marked
// `not_determined` (why, with both values) and the notes in words: what the DBB session's PARAMS carry
// (docs/protocol.md).
results::Params to_params(const CheckedIdentification& checked);
// Its JSON, results::to_json(to_params(checked)): what `identify dbb --json` prints.
nlohmann::json to_json(const CheckedIdentification& checked);

}  // namespace guideway::models::explain
