#pragma once
// JSON forms of the flatness results (CLI --json and PARAMS): units in the key names (_um, _urad, _arcsec, _mm),
// each quantity with its standard uncertainty as "u_<name>". A traverse's and a run-out's results are PARAMS'
// records too: built here as results' types (results/traverse_record.hpp, kind_records.hpp), whose to_json
// spells their keys.

#include <nlohmann/json.hpp>

#include "models/flatness/error_motion.hpp"
#include "models/flatness/runout.hpp"
#include "models/flatness/straightness.hpp"
#include "models/flatness/union_jack.hpp"
#include "results/kind_records.hpp"
#include "results/traverse_record.hpp"

namespace guideway::models::flatness {

// A traverse's result in the record's units, with its source (a session's names none: it leaves it out).
results::TraverseModelResult traverse_model_result(const StraightnessResult& r);
nlohmann::json to_json(const StraightnessResult& r);
nlohmann::json to_json(const UnionJackResult& r, bool inch_units = false);
// Mu's Eq. 21 in the record's units, without the error motion.
results::RunoutModelResult runout_model_result(const RunoutResult& r);
nlohmann::json to_json(const RunoutResult& r);
// ISO 230-7 values under their catalogue names (results/parameters.hpp), in um.
results::ErrorMotionRecord error_motion_record(const ErrorMotionResult& r);
nlohmann::json to_json(const ErrorMotionResult& r);
// `guideway identify runout`'s result, as the runout session publishes it: Mu's Eq. 21 (identify_runout) and,
// from one whole revolution on, the error motion (ISO 230-7).
results::RunoutModelResult runout_model_result(const RunoutRevolution& rev);
nlohmann::json runout_json(const RunoutRevolution& rev);
// Donaldson's reversal of two records (models/flatness/error_motion separate_reversal): `turned` states
// its artifact_turned_deg (against `first`'s, 0 when unstated) and both count their angles from the
// spindle's zero. The spindle's synchronous error motion with the artifact's form removed, the form's
// peak-to-valley, the orders left together. Throws std::invalid_argument naming the file that cannot take
// part (no turn stated, angles from the first reading, less than one whole revolution).
nlohmann::json reversal_json(const RunoutRevolution& first, const RunoutRevolution& turned);

}  // namespace guideway::models::flatness
