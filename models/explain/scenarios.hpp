#pragma once
// The EXPLAIN scenario suite (issue 7's proof): recordings generated in-process by the virtual
// machine tool with one effect switched on that the analysis model leaves out, concealed (below the
// noise, or looking like an error the model already has), plus null scenarios (noise only) and one
// whose cause is outside the library (a local guideway bump). Each scenario runs explain() and checks
// its own expectation: the right effect first, its parameter within the stated tolerance, the
// held-out RMS improved; or no finding / `unexplained` as stated. Thread safe.

#include <cstdint>
#include <string>
#include <vector>

#include "models/explain/explain.hpp"

namespace guideway::models::explain {

struct ScenarioOptions {
  bool quick = true;      // fewer samples (unit tests); false: the instrument's full density
  std::uint64_t seed = 1;  // noise seed
  // Added to every run's machine time, as a recording on a Unix-epoch clock would carry it: the
  // findings must not depend on where the clock starts.
  double clock_origin_s = 0.0;
  ExplainOptions explain;  // the engine's options (the defaults unless a bench compares settings)
};

struct ScenarioResult {
  std::string name;
  std::string model;        // dbb, flatness, straightness
  std::string effect;       // expected first finding; "" = none expected
  std::string concealment;  // how it hides
  std::string parameter;    // the checked parameter's name
  double truth = 0.0;
  double tolerance = 0.0;   // absolute
  bool expect_unexplained = false;
  std::string expect_where;  // for the out-of-library scenario: the place that must be located
  Report report;
  std::string found;         // first finding's effect, or "none"
  double found_value = 0.0;  // of `parameter` (NaN when not found)
  double found_u = 0.0;
  bool pass = false;
  std::string failure;  // why not, when !pass
};

std::vector<std::string> scenario_names();
// Throws std::invalid_argument for an unknown name.
ScenarioResult run_scenario(const std::string& name, const ScenarioOptions& options = {});
// The results table (Markdown) for docs/explain.md.
std::string scenario_table_markdown(const std::vector<ScenarioResult>& results);

}  // namespace guideway::models::explain
