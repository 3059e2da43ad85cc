// reflector_rocking: the reflector (or the carriage under it) tilts with the direction of travel.
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/traverse_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// +r moving +, -r moving -: only passes both ways tell it from the base's constant slope.
bool reflector_rocking_traverse_term(const TraverseTerms& t, Candidate& c) {
  if (!t.both_directions) return false;
  c.variants.push_back(make_variant(t.g, {results::name(results::reflector_rocking)},
                                    [](const Tp& p, double* o) { o[0] = p.direction * urad_per_arcsec; }));
  return true;
}

}  // namespace

extern const Effect reflector_rocking{
    {"reflector_rocking",
     "the reflector rocks on its mount, or the carriage tilts on its guides, with the direction of travel "
     "(the drive's force, a loose clamp)",
     "direction of travel",
     "an angle offset that flips sign between forward and return passes, the same at every station",
     {},
     {"traverse"}},
    {},
    {},
    false,
    {},
    {"the reflector or the carriage tilts one way moving forward and the other way on the return: every station reads "
     "+r forward and -r back",
     &reflector_rocking_traverse_term}};

}  // namespace guideway::models::explain::effects
