// abbe_offset: an angular error acts through an offset between the measuring line and the point of interest.
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/profile_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// Mu Eq. 14's -(sum k b_k x^(k-1)) p_x: the carriage's pitch acting through the x offset between the point
// whose path the traverse measured and the tool. Linear in the offset; only the curvature of the pitch
// separates it from squareness (a pitch linear in x makes it a line in x). Only with a measured pitch.
bool abbe_offset_profile_term(const ProfileTerms& t, Candidate& c) {
  if (!t.measured_pitch) return false;
  c.variants.push_back(make_variant(t.g, {results::name(results::abbe_offset)}, [](const Pt& p, double* o) {
    o[0] = p.pitch_rad * 1e3;  // 1 rad over 1 mm = 1e3 um
  }));
  return true;
}

}  // namespace

// Only where an angle is measured: without one, an angle curve times a constant offset is just another
// translation curve, which the straightness polynomials of the dbb and straightness bases (and Lai's roll
// term c0..c2) already absorb -- naming it there would be a guess.
extern const Effect abbe_offset{
    {"abbe_offset",
     "an angular error acts through an offset between the measuring line and the point of interest",
     "axis position",
     "the measured angle curve times the offset: on a faced part the X carriage's pitch (traverse, --straightness) "
     "times the tool's x offset, Mu Eq. 14; only the pitch's curvature separates it from squareness. No term without "
     "a measured angle (dbb, straightness: it is part of their straightness base)",
     {},
     {"flatness"}},
    {},
    {"the X carriage pitches as it travels, and the tool sits at an offset along x from the point whose straightness "
     "the autocollimator measured, so the measured pitch times that offset adds to the height",
     &abbe_offset_profile_term}};

}  // namespace guideway::models::explain::effects
