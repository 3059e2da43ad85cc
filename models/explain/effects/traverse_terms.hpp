#pragma once
// What the autocollimator traverse terms of the effects are built from (traverse_explain.cpp fills one per
// problem): each reading's pass, station, time and direction, and the yaw read beside the pitch.

#include <cstddef>
#include <vector>

#include "models/explain/explain.hpp"

namespace guideway::models::explain::effects {

inline constexpr double urad_per_arcsec = 4.84813681109536;  // what is explained is in urad (um/m)
// A pitch wave's shortest period, in station pitches: below the stations' Nyquist (2) with room to resolve it.
inline constexpr double pitch_wave_shortest_stations = 2.5;

struct Tp {
  std::size_t run;
  double x_m;       // the reading's station: the mirror, midway between the feet
  double t_s;       // on its file's clock, from the file's first reading
  int direction;    // +1 / -1
  double yaw_urad;  // 0 when no yaw was read
};

struct TraverseTerms {
  const std::vector<Tp>& g;
  bool both_directions = false;  // passes each way: what flips with the direction is seen
  bool timed = false;            // every reading has its time, and time does not follow x alone
  bool yaw = false;              // a yaw reading beside every pitch reading
  double span_m = 0.0;           // the stations' extent
  double step_m = 0.0;           // the smallest station pitch of the passes
};

}  // namespace guideway::models::explain::effects
