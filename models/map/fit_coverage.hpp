#pragma once
// What the day's tests can see: the first step of the map's fit (models/map/fit.cpp). Which of the 21
// functions and the three squarenesses the tests determine, the Legendre orders each may carry (at most half
// as many as the positions read), and for the rest why not and which test would determine it (a squareness
// the ballbar reads together with an error no test determined included). Internal to models/map; thread safe.

#include "models/map/error_map.hpp"
#include "models/map/fit.hpp"
#include "models/map/map_inputs.hpp"

namespace guideway::models::map::detail {

// The map to fill: which functions and squarenesses the day's tests see, the orders each may carry, and the
// parameters of those (at the highest orders).
ErrorMap structure(const MapInputs& in, const FitOptions& o);

}  // namespace guideway::models::map::detail
