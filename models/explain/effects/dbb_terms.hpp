#pragma once
// What the DBB terms of the effects are built from: the per-sample geometry of the runs (models/dbb's, with
// the circle's centre and a machine time), the drives' motion when they follow the command late, and the
// base. dbb_explain.cpp fills one DbbTerms per problem. Pure functions; thread safe.

#include <array>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "formats/dbb_run.hpp"
#include "models/dbb/geometry.hpp"
#include "models/explain/explain.hpp"

namespace guideway::models::explain::effects {

// Per-sample geometry and what EXPLAIN's effects add to it.
struct Geo : dbb::SampleGeometry {
  double center_a_m = 0, center_b_m = 0;  // the circle's centre, where a lagging drive's position is reckoned from
  double t_s = 0;  // machine time since the earliest run's start (or run time when not all runs have start_time_s)
};

// The drives' motion on the circle when they follow the command `delay_s` late, per sample: their
// positions, the signs of their velocities and how far each has moved from its last extreme (the last
// reversal). Computed once per problem for every delay searched (the backlash and cyclic terms live on
// the drives' positions, and their generators run many times).
struct DriveTrack {
  double delay_s = 0;
  std::vector<double> pos_a, pos_b;    // m
  std::vector<double> vel_a, vel_b;    // sign of the velocity, -1 / 0 / +1
  std::vector<double> rise_a, rise_b;  // r (1 - cos phi), phi the angle past the axis's last reversal (m)
};

// The delays (s) by which the drives may follow the commanded angle of the runs, for the terms that live
// on the drives' positions (backlash, cyclic error): none when every run's angles were read from the axis
// encoders (metadata angle_source = encoders, as a live session writes), else a grid up to a slow position
// loop's 1/Kv (commanded angles, or angles from time and feed as a ballbar's software computes them).
std::vector<double> drive_delays_s(const std::vector<formats::DbbRun>& runs);
std::shared_ptr<const std::vector<DriveTrack>> drive_tracks(const std::vector<Geo>& g,
                                                            const std::vector<double>& delays);

// Lost motion per unit backlash of a deadband of width b_a / b_b (m) along each axis ({a, b}) at
// sample i of the track.
std::array<double, 2> lost_motion(const DriveTrack& t, std::size_t i, double b_a, double b_b);

struct DbbTerms {
  const std::vector<Geo>& g;
  const std::vector<formats::DbbRun>& runs;
  bool machine_time = false;              // every run has start_time_s: one clock for all runs
  const std::vector<double>& reading_um;  // the reading the model predicts per sample (the sensor's operating point)
  std::shared_ptr<const std::vector<DriveTrack>> tracks;  // one per delay of drive_delays_s
  std::string plane;                                      // "xy", "xz", "yz"
  // The base and what is explained when the base is refitted (null for a given simulation): the terms
  // built from the base's prediction (servo_lag; sensor_nonlinearity's reading) need them.
  const Block* base = nullptr;
  const Eigen::VectorXd* y_um = nullptr;
};

}  // namespace guideway::models::explain::effects
