#pragma once
// The observation groups of the map's fit (models/map/fit.cpp): one test's readings each, with the
// first-order derivatives of their model with respect to the map's parameters and the group's own set-up
// terms, and the exact prediction through the chain. Internal to models/map; thread safe (groups are
// immutable once built).

#include <array>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "models/map/error_map.hpp"
#include "models/map/map_inputs.hpp"

namespace guideway::models::map::detail {

// "X", "Y", "Z": an axis as the groups and the map's notes name it.
std::string axis_upper(int axis);

enum class GroupKind { artifact_displacement, artifact_angles, artifact_roll_again, traverse, ballbar };

class Group {
 public:
  virtual ~Group() = default;
  GroupKind kind = GroupKind::traverse;
  std::string name;   // "artifact X displacements", "traverse Y", "ballbar xy"
  std::string test;   // the test it is part of, as the map names its sources: "artifact X", "traverse Y", "ballbar xy"
  std::string unit;   // for people: "um" or "arcsec"
  double unit_per_si = 1e6;
  int axis = -1;      // the axis it runs along (artifact, traverse); -1 for a ballbar plane
  std::string plane;  // a ballbar's
  std::vector<double> y;      // readings (SI)
  std::vector<double> sigma;  // a reading's standard deviation as the test states it (SI)
  std::vector<std::string> nuisance_names;
  // The readings' stated uncertainties come from the test's own propagation (the artifact's): the fit widens
  // them when the readings scatter more, never narrows them (a few readings' scatter is a poor estimate).
  // Otherwise (a ballbar, a traverse) the noise is estimated from the residuals alone.
  bool stated_sigma = false;
  // False: a second reading of a quantity whose errors share part of another group's (the artifact's roll in its
  // second placement, against the same calibration): compared with it, not fitted with it.
  bool in_fit = true;

  [[nodiscard]] std::size_t rows() const { return y.size(); }
  [[nodiscard]] std::size_t nuisance() const { return nuisance_names.size(); }
  // rows x (map.parameters + nuisance()): the map's columns, then the group's own.
  virtual void jacobian(const ErrorMap& map, Eigen::MatrixXd& j) const = 0;
  // The exact model of every reading at the map's parameters and the group's terms `nuisance`.
  virtual void predict(const ErrorMap& map, const double* nuisance, double* out) const = 0;
};

// The backlash of a ballbar plane's two axes (m) that shapes their lost motion: a deadband of that width is
// taken up after each reversal (models/dbb/geometry.hpp); 0 = an ideal step.
using DeadbandWidths = std::map<std::string, std::array<double, 2>>;

// The groups of the inputs, the map's chain and tool offset from `map` (travel: the other axes of a
// traverse stand at the middle of theirs). Throws std::invalid_argument naming an unusable test.
std::vector<std::unique_ptr<Group>> make_groups(const MapInputs& inputs, const ErrorMap& map,
                                                std::size_t ballbar_samples_per_run,
                                                const DeadbandWidths& deadbands = {});
// A ballbar plane's backlash estimates (its terms named "... backlash a", "... backlash b") from the group's
// terms `nuisance` (SI), or nullopt for another group.
std::optional<std::array<double, 2>> backlash_of(const Group& group, const double* nuisance);

// The local in-plane model of a ballbar plane (the ballbar diagnostics' geometric terms, docs/conventions.md):
// columns squareness (rad), straightness bow of a along b and of b along a (m, over the circle's radius),
// the cubic straightness difference (a3 - b3) r^3 (m) and the scale mismatch s_a - s_b (relative), as
// derivatives of the plane's readings; names in the diagnostics' terms.
struct LocalModel {
  std::vector<std::string> names;  // "squareness_urad", "straightness_x_um", ...
  std::vector<double> unit_per_si;
  Eigen::MatrixXd columns;  // rows x names.size()
};
LocalModel local_model(const Group& ballbar_plane);

}  // namespace guideway::models::map::detail
