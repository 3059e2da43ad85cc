#pragma once
// Offline measurement files from the virtual machine tool, in the formats the `guideway identify`
// commands read (docs/formats.md): Mu's workpiece experiment (faced-workpiece profiles at given
// feeds, the autocollimator traverse of the X carriage, a run-out revolution) and Wei's 1-D artifact
// (calibration, horizontal and vertical placements). Each function returns the file's text, so
// tests need no files; write_* put them into a directory. Pure functions of the machine and the
// spec (seeded noise); thread safe.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "simulators/machine/machine.hpp"

namespace guideway::simulators::emulators {

// Mu 2012 Sec. 4: a facing cut along X at constant feed and spindle speed, profiled every
// `profile_step`; the X carriage traversed with an autocollimator (reflector feet `step` apart, the
// mirror midway between them); a thrust plate of diameter 2 * probe_radius turned once.
struct WorkpieceFilesSpec {
  double x_start_m = 0.0;
  double traverse_m = 0.6;
  double spindle_rpm = 110.0;
  double profile_step_m = 0.05e-3;
  double step_m = 0.01;         // autocollimator foot spacing
  std::size_t passes = 1;       // traverse passes, forward and back (> 1: with t_s and pass columns)
  double dwell_s = 1.0;         // time per traverse station
  double turn_s = 10.0;         // between the passes
  double probe_radius_m = 0.5;  // run-out probe at the rim of a 1000 mm plate (Mu: L = 1000 mm)
  // p of Eq. 21 written into the run-out file (a set-up value measured apart); unset: the machine's
  // plate parallelism times the plate diameter, i.e. measured without error.
  std::optional<double> parallelism_m;
  std::uint64_t seed = 0;  // 0 = the machine's noise seed
};

std::string workpiece_profile_csv(const machine::Machine& machine, const WorkpieceFilesSpec& spec,
                                  double feed_mm_per_min);
std::string straightness_traverse_csv(const machine::Machine& machine, const WorkpieceFilesSpec& spec);
std::string runout_revolution_csv(const machine::Machine& machine, const WorkpieceFilesSpec& spec);

// Writes profile_<feed>mm_per_min.csv per feed, straightness.csv and runout.csv into `dir`; returns
// the paths written. Throws std::runtime_error naming a file that cannot be written.
std::vector<std::string> write_workpiece_files(const machine::Machine& machine, const WorkpieceFilesSpec& spec,
                                               const std::vector<double>& feeds_mm_per_min, const std::string& dir);

// Wei 2019: an artifact of `targets` targets (plane mirror + paraboloid) `pitch` apart, measured by
// an angle sensor on the tool. The artifact itself is imperfect (feature points scattered by
// `position_scatter`, mirrors tilted by `tilt_scatter`, fixed by `artifact_seed`); the calibration
// sees it on a perfect reference (laser with `laser_noise`), the machine in the horizontal and the
// vertical placement with its six error functions (machine::Machine::artifact_measurement). Every spot
// has white noise `spot_noise_px`. Spot model: docs/formats.md, "1-D artifact".
struct ArtifactFilesSpec {
  machine::Axis axis = machine::Axis::x;
  double start_m = 0.05;
  double pitch_m = 0.05;
  std::size_t targets = 9;
  machine::Vec3 other{};
  double k_m_per_px = 1.6e-6;                                // Wei: 1 px = 1.6 um
  double m_px_per_rad = 1.0 / (2.27 * 4.84813681109536e-6);  // Wei: 1 px = 2.27 arcsec
  double spot_noise_px = 0.1;                                // Wei: sub-pixel extraction, ~0.2 arcsec
  double laser_noise_m = 0.05e-6;
  double position_scatter_m = 20e-6;
  double tilt_scatter_rad = 10 * 4.84813681109536e-6;
  std::uint64_t artifact_seed = 2019;
  std::uint64_t seed = 0;  // measurement noise; 0 = the machine's noise seed
};

struct ArtifactFiles {
  std::string calibration;
  std::string horizontal;
  std::string vertical;
  std::string k_scan;  // the reference sensor moved across target 0's paraboloid, +-50 um in 21 steps
  std::string m_scan;  // target 0's mirror tilted on the reference, +-20 arcsec in 21 steps
};
ArtifactFiles artifact_files(const machine::Machine& machine, const ArtifactFilesSpec& spec);
// calibration.csv, horizontal.csv, vertical.csv, k_scan.csv, m_scan.csv into `dir`; returns the paths.
std::vector<std::string> write_artifact_files(const machine::Machine& machine, const ArtifactFilesSpec& spec,
                                              const std::string& dir);

}  // namespace guideway::simulators::emulators
