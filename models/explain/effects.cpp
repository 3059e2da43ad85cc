// The library of EXPLAIN's effects: the table of models/explain/effects/<name>.cpp, one line each.
#include "models/explain/effects.hpp"

#include <stdexcept>

#include "models/explain/effects/effect.hpp"

namespace guideway::models::explain {

namespace effects {

extern const Effect backlash, reversal_spike, lateral_play, servo_mismatch, servo_lag, cyclic_error, thermal_drift,
    vibration, stick_slip, scale_mismatch, squareness, straightness, spindle_axial_runout, tool_wear, feed_marks,
    abbe_offset, cosine_error, sensor_nonlinearity;

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
  };
  return table;
}

const Effect* find(std::string_view name) {
  for (const Effect* e : library())
    if (e->info.name == name) return e;
  return nullptr;
}

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
