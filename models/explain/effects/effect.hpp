#pragma once
// One effect of EXPLAIN's library, one file each (models/explain/effects/<name>.cpp): what it is (its
// EffectInfo: the physics in one sentence, where it lives, its signature), and for each base model that has
// a candidate term for it, the sentence a finding gives and the function that builds the term's variants
// (with its parameters' names from results/parameters.hpp). The library is the table of these files
// (models/explain/effects.cpp); dbb_explain and profile_explain loop over it. Thread safe.

#include <numbers>
#include <string>
#include <vector>

#include "models/explain/effects.hpp"

namespace guideway::models::explain {
struct Candidate;  // explain.hpp: an effect file with no term does not need the engine (nor Eigen)
}  // namespace guideway::models::explain

namespace guideway::models::explain::effects {

inline constexpr double pi = std::numbers::pi;

struct DbbTerms;       // what a DBB term is built from (dbb_terms.hpp)
struct ProfileTerms;   // what a profile term is built from (profile_terms.hpp)
struct RunoutTerms;    // what a spindle run-out term is built from (runout_terms.hpp)
struct TraverseTerms;  // what an autocollimator traverse term is built from (traverse_terms.hpp)

// A model's candidate term for an effect: the finding's sentence and what fills the candidate's
// variants, generator and search size (false: no term for these runs, e.g. no measured angle).
template <class Terms>
struct Term {
  std::string why;  // the physics as a finding of this model states it
  bool (*build)(const Terms& terms, Candidate& candidate) = nullptr;
};

struct Effect {
  EffectInfo info;
  Term<DbbTerms> dbb;          // build == nullptr: no DBB term
  Term<ProfileTerms> profile;  // build == nullptr: no term for profiles (flatness, straightness)
  // The effect lives on a few samples per run (a spike, a jerk) or on a few hundredths of a um: the
  // scenario suite simulates it at the instrument's full sample density.
  bool needs_dense_sampling = false;
  Term<RunoutTerms> runout = {};      // build == nullptr: no term for a spindle run-out record
  Term<TraverseTerms> traverse = {};  // build == nullptr: no term for autocollimator traverses
};

// The library, in its order (effects.cpp: one line per effect file).
const std::vector<const Effect*>& library();
// The effect named `name`; nullptr for an unknown one.
const Effect* find(std::string_view name);

// The candidates of each base model: every effect's term it offers for these runs, named and explained
// from the library, in the library's order (effects.cpp).
std::vector<Candidate> dbb_candidates(const DbbTerms& terms);
std::vector<Candidate> profile_candidates(const ProfileTerms& terms);
std::vector<Candidate> runout_candidates(const RunoutTerms& terms);
std::vector<Candidate> traverse_candidates(const TraverseTerms& terms);

}  // namespace guideway::models::explain::effects
