// angle_drift: the autocollimator's zero, or the air its beam crosses, drifts with time.
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/traverse_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// A rate in arcsec per minute of each file's clock. Only when the readings have times that do not follow
// the station alone (a return or a repeat): in one pass time is a line in x, which the base's slope holds.
bool angle_drift_traverse_term(const TraverseTerms& t, Candidate& c) {
  if (!t.timed) return false;
  c.variants.push_back(make_variant(t.g, {results::name(results::angle_drift)},
                                    [](const Tp& p, double* o) { o[0] = p.t_s / 60.0 * urad_per_arcsec; }));
  return true;
}

}  // namespace

extern const Effect angle_drift{
    {"angle_drift",
     "the autocollimator's zero, or the air its beam crosses, drifts with time (warm-up, a temperature gradient)",
     "time",
     "forward and return readings at the same station disagree by a trend in the time between them",
     {},
     {"traverse"}},
    {},
    {},
    false,
    {},
    {"the reading drifts with time (the instrument warming up, the air along the beam changing): forward and return "
     "disagree at each station by the rate times the time between the two readings",
     &angle_drift_traverse_term}};

}  // namespace guideway::models::explain::effects
