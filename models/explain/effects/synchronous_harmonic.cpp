// synchronous_harmonic: an error motion of the spindle (or the artifact's form) that repeats every
// revolution, a harmonic of order 2 or more of the spindle angle.
#include <string>

#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/runout_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// Every order from 2 to the highest the sampling resolves, each its own group (a spindle shows several).
bool synchronous_harmonic_runout_term(const RunoutTerms& t, Candidate& c) {
  for (int k = 2; k <= static_cast<int>(t.highest_order); ++k) {
    Variant v = line_variant(t, k, results::synchronous_harmonic, results::synchronous_harmonic_phase);
    v.group = "order " + std::to_string(k);
    c.variants.push_back(std::move(v));
  }
  return !c.variants.empty();
}

}  // namespace

extern const Effect synchronous_harmonic{
    {"synchronous_harmonic",
     "the spindle's error motion (bearing race waviness) or the artifact's form repeats every revolution",
     "spindle angle",
     "a sinusoid at a whole number of cycles per revolution, the same in every revolution",
     {},
     {"runout"}},
    {},
    {},
    false,
    {"a whole number of waves per revolution that every revolution repeats: the spindle's synchronous error motion "
     "and the artifact's form together (a record with the artifact turned 180 deg separates them)",
     &synchronous_harmonic_runout_term}};

}  // namespace guideway::models::explain::effects
