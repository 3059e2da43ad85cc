#pragma once
// Small statistics of a sampled series that models, reports and sessions all need, in one place so
// that a report's figure and a published parameter are computed alike. NaN marks an invalid point.

#include <vector>

namespace guideway::dsp {

// Root mean square of every value (a NaN makes it NaN); 0 for an empty series.
[[nodiscard]] double rms(const std::vector<double>& v);

// Highest minus lowest valid value; NaN when no value is valid.
[[nodiscard]] double peak_to_valley(const std::vector<double>& v);

// The series with each run of invalid points bridged linearly between its valid neighbours and held
// at the ends (a transform needs every point). A series without a valid point is returned as it is.
[[nodiscard]] std::vector<double> fill_gaps_linear(const std::vector<double>& v);

}  // namespace guideway::dsp
