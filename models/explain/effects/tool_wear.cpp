// tool_wear: the tool wears with the length of cut, so the depth of cut decreases.
#include <cmath>
#include <limits>
#include <numbers>

#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/profile_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// Length cut so far on a face: the spiral from the cut start, pi |x^2 - x0^2| / feed per rev.
bool tool_wear_profile_term(const ProfileTerms& t, Candidate& c) {
  std::vector<double> x0(t.runs.size(), std::numeric_limits<double>::quiet_NaN());
  for (const auto& p : t.g)
    if (std::isnan(x0[p.run])) x0[p.run] = p.x_mm;
  c.variants.push_back(make_variant(t.g, {results::name(results::tool_wear)}, [x0](const Pt& p, double* o) {
    const double fpr_mm = p.feed_mm_per_min / p.rpm;
    o[0] = std::numbers::pi * std::abs(p.x_mm * p.x_mm - x0[p.run] * x0[p.run]) / fpr_mm * 1e-3;  // metres cut
  }));
  return true;
}

}  // namespace

extern const Effect tool_wear{
    {"tool_wear",
     "the tool wears with the length of cut, so the depth of cut decreases",
     "cut length",
     "a trend in the length cut so far (quadratic in the radius on a faced surface)",
     {},
     {"flatness", "straightness"}},
    {},
    {"the tool wears with the length it has cut, so the depth of cut falls along the spiral", &tool_wear_profile_term}};

}  // namespace guideway::models::explain::effects
