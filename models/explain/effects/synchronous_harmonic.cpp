// synchronous_harmonic: an error motion of the spindle (or the artifact's form) that repeats every
// revolution, a harmonic of order 2 or more of the spindle angle.
#include <string>

#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/runout_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// Every order from 2 to the highest the sampling resolves, each its own group (a spindle shows several).
// With a reversal, at the spindle's angle over every record (the form turning with the artifact is
// artifact_form's); else a phase per record.
bool synchronous_harmonic_runout_term(const RunoutTerms& t, Candidate& c) {
  for (int k = 2; k <= static_cast<int>(t.highest_order); ++k) {
    Variant v = t.reversal ? reversal_line_variant(t, k, false, results::synchronous_harmonic,
                                                   results::synchronous_harmonic_phase)
                           : line_variant(t, k, results::synchronous_harmonic, results::synchronous_harmonic_phase);
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
     "and the artifact's form together, or the spindle's alone at an order a reversal separates (records with the "
     "artifact turned between them: its form is then artifact_form)",
     &synchronous_harmonic_runout_term}};

}  // namespace guideway::models::explain::effects
