#pragma once
// JSON form of the 1-D artifact identification (CLI --json): units in the key names, standard
// uncertainties as "u_<name>" (docs/cli.md).

#include <nlohmann/json.hpp>

#include "models/artifact/artifact.hpp"

namespace guideway::models::artifact {

nlohmann::json to_json(const ArtifactResult& r);

}  // namespace guideway::models::artifact
