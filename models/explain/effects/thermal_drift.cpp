// thermal_drift: warm-up growth of the machine or the instrument with time.
#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/profile_terms.hpp"
#include "models/explain/effects/runout_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// The drift's columns in direction(s) `axes` (0 the bar, 1 axis a, 2 axis b): a rate per minute of
// machine time, and without a common time axis each run after the first its own offset (`offsets`).
std::vector<std::string> drift_names(const std::vector<int>& axes, std::size_t offsets, const std::string& plane) {
  const auto along = [&](int a) { return results::axis_letter(plane, a - 1); };
  std::vector<std::string> names;
  for (int a : axes)
    names.push_back(a == 0 ? results::name(results::bar_drift) : results::name_along(results::centre_drift, along(a)));
  for (int a : axes)
    for (std::size_t k = 1; k <= offsets; ++k)
      names.push_back(a == 0 ? results::name_along(results::bar_drift_offset, {}, static_cast<int>(k + 1))
                             : results::name_along(results::centre_drift_offset, along(a), static_cast<int>(k + 1)));
  return names;
}

bool thermal_drift_dbb_term(const DbbTerms& t, Candidate& c) {
  const std::size_t nr = t.runs.size();
  // Without a common time axis each run after the first gets its own offset, in the drift's own
  // direction(s): the bar's reading, or the circle's centre along an axis (a projection on the bar).
  const std::size_t offsets = t.machine_time ? 0 : nr - 1;
  // Directions: 0 the bar; 1 axis A, 2 axis B; 3 the centre in the plane (A and B, each its own rate).
  for (int which = 0; which < 4; ++which) {
    std::vector<int> axes;  // 0 bar, 1 A, 2 B
    if (which == 3)
      axes = {1, 2};
    else
      axes = {which};
    Variant v = make_lazy_variant(t.geo, drift_names(axes, offsets, t.plane), [=](const Geo& p, double* o) {
      for (std::size_t j = 0; j < axes.size(); ++j) {
        const int a = axes[j];
        const double proj = a == 0 ? 1.0 : p.lambda * (a == 1 ? p.c : p.s);
        o[j] = proj * p.t_s / 60.0;
        if (offsets && p.run >= 1) o[axes.size() + j * offsets + p.run - 1] = proj;
      }
    });
    v.group = which == 0 ? "bar" : "centre";
    c.variants.push_back(std::move(v));
  }
  return true;
}

bool thermal_drift_profile_term(const ProfileTerms& t, Candidate& c) {
  c.variants.push_back(
      make_variant(t.g, {results::name(results::profile_drift)}, [](const Pt& p, double* o) { o[0] = p.t_s / 60.0; }));
  return true;
}

// The spindle's axial growth: a rate per minute of each record's time (each record's offset is the base's).
bool thermal_drift_runout_term(const RunoutTerms& t, Candidate& c) {
  c.variants.push_back(
      make_variant(t.g, {results::name(results::axial_growth)}, [](const Rp& p, double* o) { o[0] = p.t_s / 60.0; }));
  return true;
}

}  // namespace

extern const Effect thermal_drift{
    {"thermal_drift",
     "warm-up growth of the machine or the instrument with time",
     "time",
     "a trend in time that maps onto position differently at each feed and start time",
     {},
     {"dbb", "flatness", "straightness", "runout"}},
    {"the machine or the bar grows as it warms up, a trend in time that the geometric terms only partly absorb",
     &thermal_drift_dbb_term},
    {"the machine grows as it warms up during the cut: a trend in time, which at one constant feed is a straight line "
     "in x like squareness, but with another slope at another feed",
     &thermal_drift_profile_term},
    false,
    {"the spindle grows along its axis as it warms up: a trend in time through the record, which no revolution repeats",
     &thermal_drift_runout_term}};

}  // namespace guideway::models::explain::effects
