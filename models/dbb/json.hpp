#pragma once
// The JSON of a DBB identification (the shape of `guideway identify dbb --json` and of the daemon's
// PARAMS message; the CLI prints it for people: cli/params_print.hpp). Unknown or non-fitted
// uncertainties are left out, never null.

#include <string>

#include <nlohmann/json.hpp>

#include "models/dbb/identify.hpp"
#include "models/dbb/three_planes.hpp"
#include "results/params.hpp"

namespace guideway::models::dbb {

// The identification as PARAMS' body (results/params.hpp): the diagnostics, Lai's terms and the terms fitted
// beside as figure groups ("diagnostics", "lai3", "beside"); the runs, the ranking, the fits, the standards'
// figures and the notes as its DBB record (results/dbb_record.hpp).
results::Params to_params(const Identification& id);
nlohmann::json to_json(const Identification& id);  // results::to_json(to_params(id))
// The summary of several planes as the DBB record's "summary" (results::DbbPlanesSummary), and its JSON
// (results::to_json(planes_record(s))).
results::DbbPlanesSummary planes_record(const PlanesSummary& s);
nlohmann::json to_json(const PlanesSummary& s);

}  // namespace guideway::models::dbb
