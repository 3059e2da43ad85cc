#pragma once
// Volumetric accuracy of an error map (docs/map.md "Volumetric accuracy"): the error vector of the tool point
// at every point of a grid over the working volume, through the map's chain with a tool offset, relative to
// the best-fit rigid-body position of the volume (what setting up a workpiece takes out: a least-squares
// translation and small rotation over the grid); the figure is the largest length of that vector over the
// grid (ISO 230-1:2012's Euclidean volumetric error E_VE taken as a maximum length, as ISO/TR 16907 states
// volumetric performance), with the ranges of its three components (E_VX, E_VY, E_VZ). Its standard
// uncertainty is propagated from the map's covariance by drawing maps (the maximum moves between points).
// Pure functions; thread safe.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "models/map/error_map.hpp"

namespace guideway::models::map {

struct VolumetricOptions {
  std::array<std::size_t, 3> points{11, 11, 11};  // grid points per axis over the map's travel
  std::optional<Vec3> tool_offset_m;              // unset: the tool the tests were made with
  std::size_t draws = 300;                        // maps drawn from the covariance for the uncertainty
  std::uint64_t seed = 1;
};

struct VolumetricAccuracy {
  double value_m = 0.0;  // largest |error| over the grid, relative to the best-fit rigid body
  double u_m = 0.0;      // standard uncertainty (spread of the drawn maps' figures and their offset)
  double u_spread_m = 0.0;
  double u_bias_m = 0.0;  // mean of the drawn maps' figures less the figure: a maximum's selection bias
  Vec3 at_m{};            // where the largest error is (axis positions)
  Vec3 error_at_m{};      // the error vector there
  std::array<double, 3> component_range_m{};  // E_VX, E_VY, E_VZ: range of each component over the grid
  double rms_m = 0.0;                         // RMS length over the grid
  Vec3 rigid_translation_m{};                 // what the rigid body took out
  Vec3 rigid_rotation_rad{};
  std::size_t points = 0;
  Vec3 tool_offset_m{};
  // Terms the map could not determine (their names): the figure leaves them out and is then not the machine's.
  std::vector<std::string> missing;
};

// The grid's points (x fastest), inclusive of the travel's ends.
std::vector<Vec3> volume_grid(const std::array<Travel, 3>& travel, const std::array<std::size_t, 3>& points);

// The error field less its least-squares rigid-body motion over the points (translation + small rotation about
// their centroid); `translation` and `rotation` receive what was taken out.
std::vector<Vec3> relative_to_rigid_body(const std::vector<Vec3>& at, const std::vector<Vec3>& error,
                                         Vec3* translation = nullptr, Vec3* rotation = nullptr);

// The figure of any error field on points (e.g. the virtual machine's own), without uncertainty.
VolumetricAccuracy field_accuracy(const std::vector<Vec3>& at, const std::vector<Vec3>& error);

// The map's figure with its uncertainty.
VolumetricAccuracy volumetric_accuracy(const ErrorMap& map, const VolumetricOptions& options = {});

// A definition of the figure in words, for reports and files.
std::string volumetric_definition();

}  // namespace guideway::models::map
