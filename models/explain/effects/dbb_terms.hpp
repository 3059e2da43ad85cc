#pragma once
// What the DBB terms of the effects are built from: the per-sample geometry of the runs (models/dbb's, with
// the circle's centre and a machine time), the drives' motion when they follow the command late, and the
// base. dbb_explain.cpp fills one DbbTerms per problem. Pure functions; thread safe.

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
  double t_s = 0;  // machine time since the earliest run's start (or run time when not all runs have start_time_s)
};

// The drives' tracks (models/dbb/geometry: the deadband and the drives' positions) at every delay of
// dbb::drive_delays_s, shared by the generators of the terms that live on them.
std::shared_ptr<const std::vector<dbb::DriveTrack>> drive_tracks(const std::vector<Geo>& g,
                                                                 const std::vector<double>& delays);
// The drive delay a step past the grid's longest (Variant::beyond), the grid's last step again (100 ms: 120 ms): a
// slower position loop is as physical. NaN where no delay is searched (one track: the encoders' angles). The grid's
// shortest, 0, is a bound of the physics (the drives do not lead their command), not an edge: nothing is tried below.
double delay_past_grid_s(const std::vector<dbb::DriveTrack>& tracks);

struct DbbTerms {
  const std::vector<Geo>& g;
  std::shared_ptr<const std::vector<Geo>> geo;  // g itself, for the generators that keep it
  const std::vector<formats::DbbRun>& runs;
  bool machine_time = false;              // every run has start_time_s: one clock for all runs
  const std::vector<double>& reading_um;  // the reading the model predicts per sample (the sensor's operating point)
  std::shared_ptr<const std::vector<dbb::DriveTrack>> tracks;  // one per delay of dbb::drive_delays_s
  std::string plane;                                           // "xy", "xz", "yz"
  // The base refitted to the rows in use and predicted on every row (null for a given simulation): the terms
  // built from the base's prediction (servo_lag; sensor_nonlinearity's reading) share it.
  std::shared_ptr<const BasePredictions> base;
};

}  // namespace guideway::models::explain::effects
