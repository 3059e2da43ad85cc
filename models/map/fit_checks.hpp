#pragma once
// The cross-checks of the map's fit (models/map/fit.cpp, FitOptions::cross_checks): where two tests determine
// one quantity, each determination from its own readings, compared within their uncertainties (k = 2): a
// function's angles from a traverse and an artifact (or the artifact's two placements' rolls), a ballbar
// plane's own terms against what the map from the other tests predicts for them, the run-out plate's
// squareness against the ballbar's. Internal to models/map; thread safe.

#include <vector>

#include "models/map/error_map.hpp"
#include "models/map/fit.hpp"
#include "models/map/fit_solver.hpp"
#include "models/map/map_inputs.hpp"

namespace guideway::models::map::detail {

// `m`: the map the fit filled (its highest orders); `result`: the fitted map (fit.cpp's result_map).
std::vector<CrossCheck> cross_checks(const MapInputs& in, const Fitted& fitted, const ErrorMap& m,
                                     const ErrorMap& result, const std::vector<FunctionColumns>& fc);

}  // namespace guideway::models::map::detail
