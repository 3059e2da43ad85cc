#pragma once
// What the profile terms of the effects are built from (profile_explain.cpp fills one per problem): the
// points of the profiles of a faced workpiece with their machine time and cut, the runs, and the base.

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "models/explain/explain.hpp"
#include "models/explain/profile_explain.hpp"

namespace guideway::models::explain::effects {

struct Pt {
  std::size_t run;
  double x_mm, t_s, y_um, feed_mm_per_min, rpm;
  double pitch_rad = 0.0;  // measured pitch of the X carriage at x (Eq. 12), when a traverse is given
};

struct ProfileTerms {
  const std::vector<Pt>& g;
  const std::vector<ProfileRun>& runs;
  const std::vector<double>& reading_um;  // the reading the base predicts per point (the sensor's operating point)
  bool measured_pitch = false;            // a straightness traverse gave each point its carriage pitch
  // The base and what is explained when the base is refitted (null for a given prediction), and the known
  // curve added to the base's reading (the measured straightness; empty = none).
  const Block* base = nullptr;
  const Eigen::VectorXd* y_um = nullptr;
  const std::vector<double>* offset_um = nullptr;
};

}  // namespace guideway::models::explain::effects
