#pragma once
// An explanation as every layer above the models reads it: the body of an EXPLAIN message (docs/protocol.md
// "EXPLAIN", docs/explain.md), what `guideway explain --json` prints and a session's NAME.explain.json holds.
// The models build it (models/explain/explanation.hpp), the sessions return it, and the daemon, the report,
// the fleet and the CLI read its fields: its JSON is written by to_json and read by explanation_from_json
// only, so each of its keys is spelled in results/explanation.cpp and nowhere else. A number the JSON may
// give as null (not computed, not finite; an uncertainty found by a search on a grid) is NaN here. Pure;
// thread safe.

#include <cstddef>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace guideway::results {

inline constexpr double explain_nan = std::numeric_limits<double>::quiet_NaN();

// A fit's figures: the base model's ("baseline") or the final one, in sample and on held-out data.
struct ExplainFit {
  double rms_um = explain_nan;
  double bic = explain_nan;
  double heldout_rms_um = explain_nan;
  std::size_t parameters = 0;
  friend bool operator==(const ExplainFit&, const ExplainFit&) = default;
};

// A finding's parameter: its value and standard uncertainty (NaN: found by a search on a grid).
struct ExplainEstimate {
  double value = explain_nan;
  double u = explain_nan;
  friend bool operator==(const ExplainEstimate&, const ExplainEstimate&) = default;
};

// A localized structure in every domain the user can act on (models/explain/explain_result.hpp Location):
// the run and its file, the place, the time from the run's start (or, where the run has no times, the
// readings' order from its first: `timed` false) and on the machine clock (NaN: the runs share none).
struct ExplainLocation {
  std::string run;
  std::string source;
  std::pair<double, double> where{explain_nan, explain_nan};
  std::pair<double, double> from_run_start{explain_nan, explain_nan};  // s, or readings where !timed
  bool timed = true;
  std::pair<double, double> t_machine_s{explain_nan, explain_nan};
  double peak_um = explain_nan;
  std::vector<std::string> repeats_in;  // other runs with structure at the same place (empty: once)
  bool set_aside = false;               // its samples were left out of the fit of the findings
  friend bool operator==(const ExplainLocation&, const ExplainLocation&) = default;
};

// Where a residual is structured: its domain, place and band, the evidence, the places in domain units and,
// for localized structure, run by run.
struct ExplainPlace {
  std::string domain;
  std::string where;
  std::string band;
  std::string evidence;
  std::vector<std::pair<double, double>> ranges;
  std::vector<ExplainLocation> locations;
  friend bool operator==(const ExplainPlace&, const ExplainPlace&) = default;
};

struct ExplainFinding {
  std::string effect;                                 // the effect library's name: "backlash"
  std::map<std::string, ExplainEstimate> parameters;  // by reported name (results/parameters.hpp)
  double delta_bic = explain_nan;
  double p_value = explain_nan;  // Bonferroni-adjusted F-test
  double rms_um_after = explain_nan;
  double heldout_rms_um_after = explain_nan;
  double structure_removed = explain_nan;     // share of the visible structure it removed
  double contribution_um = explain_nan;       // its fitted term's size
  double percent_of_deviation = explain_nan;  // of the deviation (Explanation::deviation)
  std::string why;
  friend bool operator==(const ExplainFinding&, const ExplainFinding&) = default;
};

// A candidate's test in the last selection round, and why it was not taken.
struct ExplainConsidered {
  std::string effect;
  double delta_bic = explain_nan;
  double p_value = explain_nan;
  std::string verdict;
  friend bool operator==(const ExplainConsidered&, const ExplainConsidered&) = default;
};

// The yardstick the findings' contributions are a part of (a DBB run's circular deviation G).
struct ExplainDeviation {
  std::string name;
  double value_um = explain_nan;
  friend bool operator==(const ExplainDeviation&, const ExplainDeviation&) = default;
};

struct ExplainResidualStep {
  std::string label;                             // "base model", "+ backlash", ...
  std::vector<std::vector<double>> residual_um;  // one curve per run, on the common x grid
  friend bool operator==(const ExplainResidualStep&, const ExplainResidualStep&) = default;
};

// The residual curves for plots (docs/explain.md "residuals"): one x grid in the domain, the runs drawn, and
// per step (the base model, then after each finding in turn) every run's residual.
struct ExplainResiduals {
  std::string domain;
  std::vector<double> x;
  std::vector<std::string> runs;
  std::vector<ExplainResidualStep> steps;
  friend bool operator==(const ExplainResiduals&, const ExplainResiduals&) = default;
};

struct Explanation {
  std::string model;
  // Why no analysis was run ("": it was): then only the model, the notes, the findings (none) and
  // `unexplained` are in its JSON (docs/protocol.md "EXPLAIN").
  std::string not_analysed;
  std::size_t n = 0;                  // samples
  std::size_t set_aside_samples = 0;  // of localized structure no effect explains, left out of the findings' fit
  double noise_um = explain_nan;      // from the finest wavelet details of the baseline residual
  std::string heldout_scheme;         // "leave-one-run-out" or "blocked k-fold (k=8)"
  ExplainFit baseline;
  std::vector<ExplainPlace> mismatch;    // where the baseline residual is structured
  std::vector<ExplainFinding> findings;  // in the order they were selected
  ExplainFit final_fit;
  bool unexplained = false;
  std::optional<ExplainDeviation> deviation;
  std::vector<ExplainPlace> remaining;  // where the final residual is still structured
  std::vector<ExplainConsidered> considered;
  std::vector<std::string> notes;
  std::optional<ExplainResiduals> residuals;
  friend bool operator==(const Explanation&, const Explanation&) = default;
};

// The explanation of a session whose data cannot be explained meaningfully: nothing was analysed, nothing
// is found and nothing is claimed explained; `reason` says why (and is its one note).
Explanation not_analysed(std::string model, const std::string& reason);

// An explanation's JSON: the EXPLAIN message's body without its header (result_header.hpp).
nlohmann::json to_json(const Explanation& explanation);

// What explanation_from_json refuses: names the field and what it is ("findings[2]: \"p_value\" is string,
// expected a number or null").
class ExplanationFormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// The explanation a JSON object holds (an EXPLAIN message: its header and any other key are ignored). A key
// that is absent takes its default (as in the short form of not_analysed, or a message of an older release);
// a key of the wrong type, or a finding without its effect, throws ExplanationFormatError. What comes from a
// broker or a file goes through here: a bad payload is an error, never undefined behaviour.
Explanation explanation_from_json(const nlohmann::json& j);

// Whether `j` is an explanation a reader can show: an object with a "findings" array and a "baseline" (an
// analysed one) or a "not_analysed" reason. What the report takes a JSON file for.
[[nodiscard]] bool is_explanation(const nlohmann::json& j);

// What an explanation found, in the EXPLAIN message's own keys and nothing else: the findings' effects and
// contributions, whether a residual is left unexplained, why it was not analysed (the fleet's history and
// status carry this of each EXPLAIN).
nlohmann::json found_json(const Explanation& explanation);

}  // namespace guideway::results
