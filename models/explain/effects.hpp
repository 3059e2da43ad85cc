#pragma once
// The library of physical effects the explanation can name: each entry says what the effect is, the
// domain it lives in, its signature in the data, and which base models already contain it (those are
// not candidates for that model). One file per effect (models/explain/effects/<name>.cpp) holds this and
// its parametric term for each model that has one; `terms` names those models (abbe_offset: flatness
// only, with a measured pitch traverse -- neither a DBB circle nor a profile alone gives an angle).
// Thread safe.

#include <string>
#include <string_view>
#include <vector>

namespace guideway::models::explain {

struct EffectInfo {
  std::string name;                     // as reported (e.g. "servo_mismatch")
  std::string meaning;                  // the physics, one sentence
  std::string domain;                   // where it lives: angle/position, time, direction, feed, reversal
  std::string signature;                // what it looks like in the residual
  std::vector<std::string> in_base_of;  // models whose base already contains it
  std::vector<std::string> terms;       // models with a candidate term for it
};

const std::vector<EffectInfo>& effect_library();
// Throws std::out_of_range for an unknown name.
const EffectInfo& effect_info(std::string_view name);

}  // namespace guideway::models::explain
