#pragma once
// The headline figures of a result: the few numbers of a PARAMS (results/params.hpp) that say how a machine is
// (circular deviation, squareness, backlash, straightness, ...), as the catalogue of parameters lists them
// per session kind (results/parameters.hpp), and what an explanation found, in a line. Pure; thread safe.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "results/explanation.hpp"
#include "results/params.hpp"

namespace guideway::fleet {

struct Headline {
  std::string name;   // stable key, with its unit: "circular_deviation_um", "backlash_x_um"
  std::string label;  // for people: "G", "backlash X"
  std::string unit;   // "µm", "µrad", "ppm"
  double value = 0.0;
  std::optional<double> u;  // standard uncertainty, when the result gives one
};

// The figures of a PARAMS of session kind `kind` that it holds, in the kind's order of headline figures
// (results::headline_parameters; docs/plant.md lists them); none for a kind without any.
[[nodiscard]] std::vector<Headline> headlines(std::string_view kind, const results::Params& params);
// Why the headline figures of a PARAMS cannot be read ("" when they can): a figure that is present but
// not a finite number. The fleet refuses such a result at ingest (fleet/payload_check.hpp).
[[nodiscard]] std::string figure_problem(std::string_view kind, const results::Params& params);

// What an explanation found, largest first, in words: "backlash 1.99 µm, vibration 0.025 µm", "nothing found",
// "unexplained", "not analysed".
[[nodiscard]] std::string found_text(const results::Explanation& e);

// Whether a figure moved between two results: |latest − previous| > k·sqrt(u_latest² + u_previous²)
// with k = 2 (moved_coverage_factor). A figure without u in either result is never flagged.
inline constexpr double moved_coverage_factor = 2.0;
[[nodiscard]] bool moved(const Headline& latest, const Headline& previous);

}  // namespace guideway::fleet
