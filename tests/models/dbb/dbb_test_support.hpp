#pragma once
// Shared helpers of the DBB tests: machines carrying Lai's "given" errors, runs from the virtual
// machine tool, tolerance checks.

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "models/dbb/identify.hpp"
#include "simulators/machine/dbb_runs.hpp"
#include "simulators/machine/machine.hpp"

namespace guideway::test {

// Lai, Liao, Chieng (1997) Tables 3 and 5, "Given" column, in Lai's units (mm-based).
struct LaiGiven {
  double e_x_um = -2.0, e_y_um = -3.0;
  double backlash_x_um = 1.0, backlash_y_um = 2.0;
  double s_x = 0.99999, s_y = 1.00001;
  double a1 = 3.0e-4, a2 = 2.25e-7, a3 = -5.0e-9;
  double b2 = 2.5e-7, b3 = 5.0e-9;
  double c0 = 0.5e-4, d1 = 1.5e-4;  // the paper gives only c0 + d1 = 2e-4
  double c1 = 2.5e-6, c2 = -5.0e-8;
  double d2 = 6.0e-7, d3 = -1.1e-8;
  double e1 = 1.0e-4, e2 = 1.5e-6, e3 = -1.5e-8;
};

// A machine whose exact HTM chain carries Lai's errors (mapping in docs/conventions.md).
inline simulators::machine::MachineConfig lai_machine(const LaiGiven& g, double noise_um) {
  simulators::machine::MachineConfig m;
  m.name = "lai1997-given";
  m.noise.seed = 1997;
  m.dbb.center_offset = {-g.e_x_um * 1e-6, -g.e_y_um * 1e-6, 0.0};
  m.dbb.noise_m = noise_um * 1e-6;
  auto& x = m.axis[0];
  auto& y = m.axis[1];
  x.scale = g.s_x - 1.0;
  y.scale = g.s_y - 1.0;
  // mm-based Lai coefficients -> SI: coefficient of u^k in m^(1-k) = a_k[mm^(1-k)] * 1e3^(k-1)... for
  // y_m = sum a_k (x_mm)^k mm = sum a_k 1e-3 (1e3 x_m)^k.
  const auto si = [](std::vector<double> mm) {
    simulators::machine::Polynomial p;
    double f = 1e-3;
    for (double c : mm) {
      p.c.push_back(c * f);
      f *= 1e3;
    }
    return p;
  };
  x.translation[1] = si({0, g.a1, g.a2, g.a3});
  x.translation[2] = si({0, g.d1, g.d2, g.d3});
  y.translation[0] = si({0, 0, g.b2, g.b3});
  y.translation[2] = si({0, g.e1, g.e2, g.e3});
  // Roll of Y: normal displacement x * c(y) = rotation about +y by -c(y) (rad; c_k in 1/mm^k).
  simulators::machine::Polynomial roll;
  double f = 1.0;
  for (double c : {g.c0, g.c1, g.c2}) {
    roll.c.push_back(-c * f);
    f *= 1e3;
  }
  y.rotation[1] = roll;
  x.backlash_m = g.backlash_x_um * 1e-6;
  y.backlash_m = g.backlash_y_um * 1e-6;
  return m;
}

inline formats::DbbRun lai_pattern(const simulators::machine::Machine& m, double radius_mm, double height_mm, bool ccw,
                                   std::uint64_t seed) {
  simulators::machine::DbbCircleSpec s;
  s.radius_m = radius_mm * 1e-3;
  s.height_m = height_mm * 1e-3;
  s.direction = ccw ? formats::DbbDirection::ccw : formats::DbbDirection::cw;
  s.seed = seed;
  return simulators::machine::simulate_dbb_run(m, s, "r" + std::to_string(radius_mm) + (ccw ? "ccw" : "cw"));
}

inline std::map<std::string, models::dbb::Estimate> by_name(const std::vector<models::dbb::Estimate>& list) {
  std::map<std::string, models::dbb::Estimate> out;
  for (const auto& e : list) out[e.name] = e;
  return out;
}

}  // namespace guideway::test
