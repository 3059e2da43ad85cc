#pragma once
// JSON form of the workpiece flatness analysis (CLI --json): units in the key names, standard
// uncertainties as "u_<name>" (docs/cli.md).

#include <nlohmann/json.hpp>

#include "models/flatness/workpiece_flatness.hpp"

namespace guideway::models::flatness {

nlohmann::json to_json(const WorkpieceFlatnessResult& r);

}  // namespace guideway::models::flatness
