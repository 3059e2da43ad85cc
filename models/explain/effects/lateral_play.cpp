// lateral_play: the carriage shifts sideways in its guideway when its direction of travel changes.
#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

bool lateral_play_dbb_term(const DbbTerms& t, Candidate& c) {
  c.variants.push_back(make_lazy_variant(
      t.geo, {results::name(results::lateral_play, t.plane, 0), results::name(results::lateral_play, t.plane, 1)},
      [](const Geo& p, double* o) {
        o[0] = p.lambda * 0.5 * p.sgn_a * p.s;
        o[1] = p.lambda * 0.5 * p.sgn_b * p.c;
      }));
  return true;
}

}  // namespace

extern const Effect lateral_play{
    {"lateral_play",
     "the carriage shifts sideways in its guideway when the direction of travel changes",
     "direction of travel",
     "a step along the other axis at each reversal of the carriage's axis",
     {},
     {"dbb"}},
    {"the carriages shift sideways in their guideways when their direction of travel changes", &lateral_play_dbb_term},
    {}};

}  // namespace guideway::models::explain::effects
