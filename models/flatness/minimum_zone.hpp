#pragma once
// Minimum-zone flatness of points (x, y, z): the smallest distance, measured along z, between two
// parallel planes enclosing all points. Solved exactly as a linear programme (the dual, with four
// equality constraints, by a two-phase simplex with Bland's rule); the optimum touches the points
// in a 3-1 or 2-2 configuration. Pure function; thread safe.

#include <cstddef>
#include <vector>

namespace guideway::models::flatness {

// The zone found: its width and the lower plane.
struct MinimumZonePlane {
  double width = 0.0;  // zone width along z
  double a = 0.0;      // zone planes: z = a x + b y + c (lower) and + width (upper)
  double b = 0.0;
  double c = 0.0;
};

// Throws std::invalid_argument when the sizes differ or fewer than 3 points are given.
MinimumZonePlane minimum_zone_flatness(const std::vector<double>& x, const std::vector<double>& y,
                                       const std::vector<double>& z);

}  // namespace guideway::models::flatness
