#pragma once
// A day's tests of the error map from the virtual machine tool (`guideway simulate day`, docs/map.md): the
// three-plane ballbar (CCW and CW at h = 0; the vertical planes' 220 deg arcs), the autocollimator traverse of
// every axis (forward and back), Wei's 1-D artifact on every axis and the run-out plate, as the files the
// daemon's sessions and the offline commands write, plus the day's manifest (`day.json`, format
// guideway/map-day/1) that `guideway map fit --day` reads. What the plan leaves out is what the map will say
// it cannot determine. Pure apart from writing the files; thread safe.

#include <array>
#include <string>
#include <vector>

#include "simulators/machine/machine.hpp"

namespace guideway::simulators::emulators {

struct DayPlan {
  // The working volume the tests cover, per axis [lo, hi] (m, machine coordinates).
  std::array<std::array<double, 2>, 3> travel_m{{{-0.2, 0.2}, {-0.2, 0.2}, {-0.15, 0.15}}};
  std::vector<std::string> planes{"xy", "xz", "yz"};  // ballbar planes (at the volume's centre)
  double ballbar_radius_m = 0.1;
  double ballbar_feed_mm_per_min = 1000.0;
  std::array<bool, 3> traverse{true, true, true};  // autocollimator traverses, x y z
  double traverse_step_m = 0.025;
  std::size_t traverse_passes = 2;
  std::array<bool, 3> artifact{true, true, true};  // 1-D artifact, x y z
  std::size_t artifact_targets = 9;
  bool runout = true;
  std::uint64_t seed = 0;  // 0: the machine's noise seed
};

struct DayTest {
  std::string kind;   // "dbb", "straightness", "artifact", "runout"
  std::string where;  // the plane or the axis ("" for the run-out)
  std::vector<std::string> files;
};

// Writes the day's files and day.json into `dir` (which must exist); returns the tests in the manifest's
// order. Throws std::runtime_error naming a file that cannot be written, std::invalid_argument for a plan
// whose ballbar circle does not fit the volume.
std::vector<DayTest> write_day_files(const machine::Machine& machine, const DayPlan& plan, const std::string& dir);

}  // namespace guideway::simulators::emulators
