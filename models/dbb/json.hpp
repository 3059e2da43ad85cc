#pragma once
// The JSON of a DBB identification (the shape of `guideway identify dbb --json` and of the daemon's
// PARAMS message; the CLI prints it for people: cli/params_print.hpp). Unknown or non-fitted
// uncertainties are left out, never null.

#include <string>

#include <nlohmann/json.hpp>

#include "models/dbb/identify.hpp"

namespace guideway::models::dbb {

nlohmann::json to_json(const Identification& id);

}  // namespace guideway::models::dbb
