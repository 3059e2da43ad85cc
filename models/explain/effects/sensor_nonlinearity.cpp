// sensor_nonlinearity: the transducer's characteristic is not linear over its range.
#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/profile_terms.hpp"

namespace guideway::models::explain::effects {

namespace {

// The reading is the sensor's operating point: the base's prediction (measuring the reading itself would
// let the term fit the very effects in it), refitted to the rows in use when the base is.
bool sensor_nonlinearity_dbb_term(const DbbTerms& t, Candidate& c) {
  if (t.base) {
    c.generate = sensor_nonlinearity_generator(t.base, {});
  } else {
    c.variants.push_back(sensor_nonlinearity_variant(t.reading_um));
  }
  return true;
}

bool sensor_nonlinearity_profile_term(const ProfileTerms& t, Candidate& c) {
  if (t.base != nullptr && t.y_um != nullptr) {
    c.generate = sensor_nonlinearity_generator(*t.base, *t.y_um, t.offset_um ? *t.offset_um : std::vector<double>{});
  } else {
    c.variants.push_back(sensor_nonlinearity_variant(t.reading_um));
  }
  return true;
}

}  // namespace

extern const Effect sensor_nonlinearity{
    {"sensor_nonlinearity",
     "the transducer's characteristic is not linear over its range",
     "reading",
     "an error that is a polynomial in the reading itself, wherever it occurs",
     {},
     {"dbb", "flatness", "straightness"}},
    {"the bar's transducer is not linear over its range, an error that is a polynomial in the reading itself",
     &sensor_nonlinearity_dbb_term},
    {"the profilometer is not linear over its range: an error polynomial in the reading",
     &sensor_nonlinearity_profile_term},
    true};

}  // namespace guideway::models::explain::effects
