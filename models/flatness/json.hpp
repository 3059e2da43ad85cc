#pragma once
// JSON forms of the flatness results (CLI --json and, later, PARAMS): units in the key names
// (_um, _urad, _arcsec, _mm), each quantity with its standard uncertainty as "u_<name>".

#include <nlohmann/json.hpp>

#include "models/flatness/runout.hpp"
#include "models/flatness/straightness.hpp"
#include "models/flatness/union_jack.hpp"

namespace guideway::models::flatness {

nlohmann::json to_json(const StraightnessResult& r);
nlohmann::json to_json(const UnionJackResult& r, bool inch_units = false);
nlohmann::json to_json(const RunoutResult& r);

}  // namespace guideway::models::flatness
