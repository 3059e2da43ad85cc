// The library of EXPLAIN's effects: the table of models/explain/effects/<name>.cpp, one line each.
#include "models/explain/effects.hpp"

#include <stdexcept>

#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/profile_terms.hpp"
#include "models/explain/effects/runout_terms.hpp"
#include "models/explain/effects/traverse_terms.hpp"

namespace guideway::models::explain {

namespace effects {

extern const Effect backlash, reversal_spike, lateral_play, servo_mismatch, servo_lag, cyclic_error, thermal_drift,
    vibration, stick_slip, scale_mismatch, squareness, straightness, spindle_axial_runout, tool_wear, feed_marks,
    abbe_offset, cosine_error, sensor_nonlinearity, synchronous_harmonic, asynchronous_line, speed_variation,
    artifact_form, speed_ripple, angle_drift, reflector_rocking, pitch_wave, yaw_coupling, compensation_step;

const std::vector<const Effect*>& library() {
  static const std::vector<const Effect*> table = {
      &backlash,
      &reversal_spike,
      &lateral_play,
      &servo_mismatch,
      &servo_lag,
      &cyclic_error,
      &thermal_drift,
      &vibration,
      &stick_slip,
      &scale_mismatch,
      &squareness,
      &straightness,
      &spindle_axial_runout,
      &tool_wear,
      &feed_marks,
      &abbe_offset,
      &cosine_error,
      &sensor_nonlinearity,
      &synchronous_harmonic,
      &asynchronous_line,
      &speed_variation,
      &artifact_form,
      &speed_ripple,
      &angle_drift,
      &reflector_rocking,
      &pitch_wave,
      &yaw_coupling,
      &compensation_step,
  };
  return table;
}

const Effect* find(std::string_view name) {
  for (const Effect* e : library())
    if (e->info.name == name) return e;
  return nullptr;
}

namespace {

template <class Terms>
std::vector<Candidate> candidates(const Terms& terms, Term<Terms> Effect::*term) {
  std::vector<Candidate> out;
  for (const Effect* e : library()) {
    const Term<Terms>& t = e->*term;
    if (t.build == nullptr) continue;
    Candidate c{e->info.name, t.why, {}, {}, 0};
    if (t.build(terms, c)) out.push_back(std::move(c));
  }
  return out;
}

}  // namespace

std::vector<Candidate> dbb_candidates(const DbbTerms& terms) { return candidates(terms, &Effect::dbb); }

std::vector<Candidate> profile_candidates(const ProfileTerms& terms) { return candidates(terms, &Effect::profile); }

std::vector<Candidate> runout_candidates(const RunoutTerms& terms) { return candidates(terms, &Effect::runout); }

std::vector<Candidate> traverse_candidates(const TraverseTerms& terms) { return candidates(terms, &Effect::traverse); }

}  // namespace effects

const std::vector<EffectInfo>& effect_library() {
  static const std::vector<EffectInfo> lib = [] {
    std::vector<EffectInfo> out;
    for (const effects::Effect* e : effects::library()) out.push_back(e->info);
    return out;
  }();
  return lib;
}

const EffectInfo& effect_info(std::string_view name) {
  if (const effects::Effect* e = effects::find(name)) return e->info;
  throw std::out_of_range("unknown effect: " + std::string(name));
}

}  // namespace guideway::models::explain
