#pragma once
// Faced-workpiece profiles for the EXPLAIN tests: two cuts at 2 and 8 mm/min, 107 rpm, 201 points over
// 20 mm, a minute apart, each point's height from `z_m(x_m)` (called in order, so it may draw noise).

#include <functional>
#include <string>
#include <vector>

#include "models/explain/profile_explain.hpp"

namespace guideway::test {

inline std::vector<models::explain::ProfileRun> two_cuts(const std::function<double(double x_m)>& z_m) {
  std::vector<models::explain::ProfileRun> runs;
  double t0 = 0;
  for (double feed : {2.0, 8.0}) {
    models::explain::ProfileRun r;
    r.source = "p" + std::to_string(runs.size() + 1) + ".csv";
    r.feed_mm_per_min = feed;
    r.spindle_rpm = 107;
    for (int i = 0; i <= 200; ++i) {
      const double x = i * 1e-4;
      r.x_m.push_back(x);
      r.z_m.push_back(z_m(x));
      r.t_s.push_back(t0 + x / (feed / 60000.0));
    }
    t0 = r.t_s.back() + 60;
    runs.push_back(std::move(r));
  }
  return runs;
}

}  // namespace guideway::test
