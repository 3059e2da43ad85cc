#pragma once
// The machine across its test planes: the identifications of circular tests in several planes (xy, xz, yz)
// brought together as a service engineer reads a three-plane test. Per plane its squareness and scale
// mismatch; per axis its backlash and scale from every plane that sees it, with whether those planes
// agree; and every plane's errors ranked together by their part of the circular deviation ("what to fix
// first" across the machine). Names: results/parameters.hpp ("planes"). Pure functions; thread safe.

#include <string>
#include <vector>

#include "models/dbb/identify.hpp"

namespace guideway::models::dbb {

// One plane's figure of an axis (or of the plane itself).
struct PlaneFigure {
  std::string plane;  // "xy", "xz", "yz"
  double value = 0.0;
  double u = 0.0;  // standard uncertainty; NaN when the plane gave no u
};

// An axis' figure from every plane that sees it. With two planes or more they agree when every pair
// differs by at most twice its combined uncertainty, |a - b| <= 2 sqrt(ua^2 + ub^2); `value` and `u` are
// then the planes' inverse-variance weighted mean (with one plane: its own figure). When they do not agree
// the mean is still given and `note` says which planes differ, by how much, against what.
struct AxisFigure {
  std::string name;  // "backlash_z_um", "scale_z_ppm"
  std::string axis;  // "x", "y", "z"
  std::vector<PlaneFigure> from;
  double value = 0.0;
  double u = 0.0;
  bool consistent = true;
  std::string note;
};

// One error of one plane and its part of the circular deviation, its percentage of the largest G of all
// the planes (so the planes' errors compare).
struct PlaneContribution {
  std::string plane;
  std::string name;  // as the plane's identification ranks it ("backlash_z_um", "scale_mismatch_ppm")
  double contribution_um = 0.0;
  double percent = 0.0;
};

struct PlanesSummary {
  std::vector<std::string> planes;         // in the order given
  std::vector<Estimate> squareness;        // squareness_{a}{b}_urad, one per plane that has it
  std::vector<Estimate> scale_mismatch;    // scale_mismatch_{a}{b}_ppm, one per plane that has it
  std::vector<AxisFigure> backlash;        // per axis (x, y, z), those some plane sees
  std::vector<AxisFigure> scale;           // per axis
  std::vector<PlaneContribution> ranking;  // largest first
  double circular_deviation_um = 0.0;      // the largest G of the planes (over each plane's data arc)
  std::vector<std::string> notes;          // missing planes, disagreements, figures a plane could not give
};

// The runs grouped by plane, in the order the planes first appear (each plane is identified on its own).
std::vector<std::vector<formats::DbbRun>> runs_by_plane(std::vector<formats::DbbRun> runs);

// `ids`: one identification per plane (each of one plane; a plane given twice is refused: throws
// std::invalid_argument, as for none).
PlanesSummary summarize_planes(const std::vector<Identification>& ids);

// Whether two figures agree within their combined uncertainty (k = 2).
[[nodiscard]] bool figures_agree(double a, double ua, double b, double ub);

}  // namespace guideway::models::dbb
