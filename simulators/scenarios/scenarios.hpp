#pragma once
// The EXPLAIN scenario suite: recordings generated in-process by the virtual machine
// tool with effects switched on that the analysis model leaves out -- one at a time, concealed (below
// the noise, or looking like an error the model already has), and several at once (pairs across the
// whole DBB library, sets of three, a centre drifting in the plane) -- plus null scenarios (noise only;
// several runs, feeds, high noise) and causes outside the library (a local guideway bump, the ball
// slipping in its socket). Each scenario runs explain() and checks its own expectation: every injected
// effect found with its parameter within the stated tolerance of the truth, nothing else found, the
// held-out RMS improved; or no finding / `unexplained` at the stated place. Thread safe.

#include <cstdint>
#include <string>
#include <vector>

#include "formats/dbb_run.hpp"
#include "models/explain/explain_result.hpp"
#include "models/explain/traverse_explain.hpp"

namespace guideway::simulators::machine {
class Machine;
}

namespace guideway::simulators::scenarios {

struct ScenarioOptions {
  bool quick = true;             // 3 samples per degree (unit tests) where an effect does not need the instrument's
                                 // 10 (spikes, jerks, the servo lag keep 10); false: 10 everywhere
  std::uint64_t seed = 1;        // noise seed
  double samples_per_deg = 0.0;  // DBB runs' sample density; 0: as `quick` says (3 or 10)
  // Added to every run's machine time, as a recording on a Unix-epoch clock would carry it: the
  // findings must not depend on where the clock starts.
  double clock_origin_s = 0.0;
  models::explain::ExplainOptions explain;  // the engine's options (the defaults unless a bench compares settings)
};

// One injected effect the scenario's model can see, and how it is checked.
struct Expectation {
  std::string effect;      // as reported (e.g. "backlash")
  std::string parameter;   // the checked parameter (e.g. "backlash_x_um")
  double truth = 0.0;      // what the virtual machine holds, in the parameter's unit
  double tolerance = 0.0;  // absolute
};

// What one scenario run found for one expectation.
struct Check {
  Expectation expected;
  bool found = false;   // a finding of the effect reports the parameter
  double value = 0.0;   // NaN when not found
  double u = 0.0;       // its standard uncertainty (NaN when searched on a grid or not found)
  bool within = false;  // |value - truth| <= tolerance
};

struct ScenarioResult {
  std::string name;
  std::string model;                  // dbb, flatness, straightness
  std::string concealment;            // what is injected and how it hides
  std::vector<Expectation> expected;  // every effect injected that the model can see; empty = none
  bool expect_unexplained = false;
  std::string expect_where;  // for a cause outside the library: the place that must be located
  std::string located;       // ... and where it was
  models::explain::Report report;
  std::vector<Check> checks;       // one per expectation
  std::vector<std::string> extra;  // findings no expectation accounts for
  bool pass = false;
  std::string failure;  // why not, when !pass
};

std::vector<std::string> scenario_names();
// The spindle run-out scenarios (runout_scenarios.cpp), part of scenario_names().
std::vector<std::string> runout_scenario_names();
ScenarioResult runout_scenario(const std::string& name, const ScenarioOptions& options);
// Passes of the virtual machine's X carriage under an autocollimator, as traverse files hold them (rear foot,
// the pitch read = - the rotation about +y; docs/formats.md): forward, return, forward, ... each `turn_s`
// after the one before, every file its own set-up with its clock from 0, each pass its own noise seed.
struct SimulatedTraverse {
  double start_m = 0.0, end_m = 0.6, step_m = 0.01;
  double dwell_s = 2.0;  // time per station
  double turn_s = 10.0;  // between the last reading of a pass and the first of the next
  std::size_t passes = 2, files = 1;
  std::uint64_t seed = 1;
};
std::vector<models::explain::TraversePass> simulated_traverse(const machine::Machine& machine,
                                                              const SimulatedTraverse& traverse);
// The autocollimator traverse scenarios (traverse_scenarios.cpp), part of scenario_names().
std::vector<std::string> traverse_scenario_names();
ScenarioResult traverse_scenario(const std::string& name, const ScenarioOptions& options);
// Every expectation of `s` against its report's findings, and the common checks (held-out RMS improved,
// unexplained as expected): fills checks, extra, pass and failure.
void check_expectations(ScenarioResult& s);
// Throws std::invalid_argument for an unknown name.
ScenarioResult run_scenario(const std::string& name, const ScenarioOptions& options = {});
// A DBB scenario's runs as the virtual machine traces them (what run_scenario explains), e.g. for the cost
// benchmark at a given sample density. Throws std::invalid_argument for a name that is not a DBB scenario.
std::vector<formats::DbbRun> scenario_dbb_runs(const std::string& name, const ScenarioOptions& options = {});

// A scenario over several noise seeds: per expectation how often it was found, the mean and scatter of
// its value, the mean reported u and the largest |value - truth| / u; the held-out RMS before and after.
struct ScenarioSummary {
  std::string name, model, concealment;
  std::vector<Expectation> expected;
  bool expect_unexplained = false;
  std::vector<std::uint64_t> seeds;
  std::vector<ScenarioResult> runs;  // one per seed
  std::size_t passed = 0;
};
ScenarioSummary summarize_scenario(const std::string& name, const std::vector<std::uint64_t>& seeds,
                                   const ScenarioOptions& options = {});

// Coverage of the reported uncertainties over every check with a finite u: the fraction of errors
// within 1 u and within 2 u (a Gaussian gives 68 % and 95 %).
struct Coverage {
  std::size_t n = 0;
  double within_1u = 0.0, within_2u = 0.0;
};
Coverage uncertainty_coverage(const std::vector<ScenarioSummary>& summaries);

// The results table (Markdown) for docs/explain.md, with a line on the coverage.
std::string scenario_table_markdown(const std::vector<ScenarioSummary>& summaries);

}  // namespace guideway::simulators::scenarios
