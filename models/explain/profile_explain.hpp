#pragma once
// EXPLAIN for profiles of a faced workpiece (x = machine X along the radius, z = surface height).
//   --model flatness:     base = Mu 2012 Eq. 16: the X carriage's straightness measured with an
//                         autocollimator (the Eq. 10 polynomial of the traverse, models/flatness,
//                         evaluated at the profile's x; a known curve, not refitted) + one offset per
//                         profile + one squareness slope shared by all profiles (a property of the
//                         machine, not of the cut). Without a traverse: offsets + squareness only (the
//                         straightness stays in the residual; a note says so).
//   --model straightness: base = one offset per profile + a cubic polynomial in x shared by all
//                         profiles (the carriage's straightness is the same in every cut).
// Candidates: every effect of the library with a profile term (models/explain/effects/): thermal_drift (a
// rate in machine time, shared), spindle_axial_runout (once and twice per spindle revolution in time),
// tool_wear (in the length cut so far), feed_marks (period = feed per revolution), cyclic_error (lead-screw
// periods in x), sensor_nonlinearity, and with a traverse abbe_offset (Eq. 14's pitch x offset term: the
// measured pitch angle times an unknown x offset). The look-alike pair: a
// drift at constant feed is a straight line in x, exactly squareness, unless two feeds are compared
// (the slope of the drift scales with 1/feed, squareness does not).
// Time of each point: start_time_s + |x - cut_start| / feed (metadata `start_time_s`, default 0, and
// `cut_start_mm`, default the first point). Pure functions; thread safe; throw std::invalid_argument.

#include <string>
#include <vector>

#include "models/explain/explain_result.hpp"
#include "models/flatness/straightness.hpp"

namespace guideway::formats {
struct Profile;
}

namespace guideway::models::explain {

struct Problem;  // explain.hpp (the engine, with Eigen): only for who builds or inspects problems

struct ProfileRun {
  std::string source;
  double feed_mm_per_min = 0.0;
  double spindle_rpm = 0.0;
  std::vector<double> x_m;
  std::vector<double> z_m;
  std::vector<double> t_s;  // machine time of each point
};

// Reads a guideway/profile/1 CSV (docs/formats.md) with feed_mm_per_min and spindle_rpm metadata and
// every point valid; errors name the file (and line).
ProfileRun read_profile_run(const std::string& path);
// The same from a parsed profile (e.g. the daemon's profile session); errors name `source`.
ProfileRun profile_run(const formats::Profile& profile, const std::string& source);

// model: "flatness" or "straightness". straightness: the autocollimator traverse of the X carriage
// (flatness::read_angle_traverse), flatness only; its x must cover every profile (throws naming both).
Problem profile_problem(const std::vector<ProfileRun>& runs, const std::string& model,
                        const flatness::AngleTraverse* straightness = nullptr);
Report explain_profiles(const std::vector<ProfileRun>& runs, const std::string& model,
                        const flatness::AngleTraverse* straightness = nullptr, const ExplainOptions& options = {});
// A given prediction against a profile (equal x within 1e-9 m), no base refit.
Problem profile_compare_problem(const ProfileRun& simulated, const ProfileRun& measured);
Report explain_profile_difference(const ProfileRun& simulated, const ProfileRun& measured,
                                  const ExplainOptions& options = {});

}  // namespace guideway::models::explain
