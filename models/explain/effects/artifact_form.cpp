// artifact_form: the artifact's own form (the thrust plate's lobing, the test ball's out-of-roundness),
// which turns with the artifact: told from the spindle's error motion only by records with the artifact
// turned between them (Donaldson's reversal).
#include <string>

#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/runout_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// With a reversal: every order a turn of the records separates, at the artifact's angle over every record.
bool artifact_form_runout_term(const RunoutTerms& t, Candidate& c) {
  if (!t.reversal) return false;
  for (int k = 2; k <= static_cast<int>(t.highest_order); ++k) {
    if (!reversal_separates(t, k)) continue;
    Variant v = reversal_line_variant(t, k, true, results::artifact_form, results::artifact_form_phase);
    v.group = "order " + std::to_string(k);
    c.variants.push_back(std::move(v));
  }
  return !c.variants.empty();
}

}  // namespace

extern const Effect artifact_form{
    {"artifact_form",
     "the artifact (a thrust plate, a test ball) is not perfectly flat or round: its form repeats every revolution "
     "like the spindle's error motion, but turns with the artifact",
     "artifact angle",
     "a whole number of waves per revolution that moves with the artifact when it is turned on the spindle",
     {},
     {"runout"}},
    {},
    {},
    false,
    {"a whole number of waves per revolution that turned with the artifact between the records: the artifact's own "
     "form, not the spindle's error motion (Donaldson's reversal)",
     &artifact_form_runout_term}};

}  // namespace guideway::models::explain::effects
