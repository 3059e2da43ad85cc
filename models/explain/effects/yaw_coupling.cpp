// yaw_coupling: the pitch reading holds a part of the yaw (the second angle measured).
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/traverse_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// The yaw reading itself, in percent: only its shape beyond the base's polynomial tells it (a yaw that is
// a smooth curve in x reads as straightness).
bool yaw_coupling_traverse_term(const TraverseTerms& t, Candidate& c) {
  if (!t.yaw) return false;
  c.variants.push_back(make_variant(t.g, {results::name(results::yaw_coupling)},
                                    [](const Tp& p, double* o) { o[0] = p.yaw_urad / 100.0; }));
  return true;
}

}  // namespace

extern const Effect yaw_coupling{
    {"yaw_coupling",
     "the autocollimator head or the reflector is turned about the beam, so the pitch channel reads a part of the "
     "yaw",
     "the second angle",
     "the pitch residual follows the yaw reading's shape, station by station",
     {},
     {"traverse"}},
    {},
    {},
    false,
    {},
    {"the head or the reflector is turned about the beam by a small angle r: the pitch reads sin r of the yaw, so the "
     "carriage's yaw couples into the straightness",
     &yaw_coupling_traverse_term}};

}  // namespace guideway::models::explain::effects
