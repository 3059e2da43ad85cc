#pragma once
// JSON forms of the flatness results (CLI --json and, later, PARAMS): units in the key names
// (_um, _urad, _arcsec, _mm), each quantity with its standard uncertainty as "u_<name>".

#include <nlohmann/json.hpp>

#include "models/flatness/error_motion.hpp"
#include "models/flatness/runout.hpp"
#include "models/flatness/straightness.hpp"
#include "models/flatness/union_jack.hpp"

namespace guideway::models::flatness {

nlohmann::json to_json(const StraightnessResult& r);
nlohmann::json to_json(const UnionJackResult& r, bool inch_units = false);
nlohmann::json to_json(const RunoutResult& r);
// ISO 230-7 values under their catalogue names (results/parameters.hpp), in um.
nlohmann::json to_json(const ErrorMotionResult& r);
// `guideway identify runout`'s result, as the runout session publishes it: Mu's Eq. 21 (to_json of
// identify_runout) and, from one whole revolution on, "error_motion" (ISO 230-7).
nlohmann::json runout_json(const RunoutRevolution& rev);
// Donaldson's reversal of two records (models/flatness/error_motion separate_reversal): `turned` states
// its artifact_turned_deg (against `first`'s, 0 when unstated) and both count their angles from the
// spindle's zero. The spindle's synchronous error motion with the artifact's form removed, the form's
// peak-to-valley, the orders left together. Throws std::invalid_argument naming the file that cannot take
// part (no turn stated, angles from the first reading, less than one whole revolution).
nlohmann::json reversal_json(const RunoutRevolution& first, const RunoutRevolution& turned);

}  // namespace guideway::models::flatness
