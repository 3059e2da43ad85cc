#pragma once
// Human-readable form of a PARAMS message (the `params`, `start --wait` and `replay` commands).

#include <nlohmann/json.hpp>

namespace guideway::cli {

// Prints every group of {"name":{"value":..,"u":..}} as an aligned table, then the fit summaries, the
// wavelet summary of a profile session, and the files involved.
void print_params(const nlohmann::json& p);

}  // namespace guideway::cli
