#include "simulators/machine/dbb_runs.hpp"

#include <sstream>

namespace guideway::sim {

formats::DbbRun simulate_dbb_run(const Machine& machine, const DbbCircleSpec& spec, const std::string& source) {
  const sim::DbbRun raw = machine.dbb_circle(spec);
  formats::DbbRun run;
  run.source = source;
  run.radius_m = spec.radius_m;
  run.height_m = spec.height_m;
  run.direction = spec.direction;
  run.feed_m_per_s = spec.feed_m_per_s;
  run.plane = spec.plane == sim::Plane::xy ? "xy" : (spec.plane == sim::Plane::xz ? "xz" : "yz");
  const int a = spec.plane == sim::Plane::yz ? 1 : 0;
  const int b = spec.plane == sim::Plane::xy ? 1 : 2;
  run.center_a_m = spec.center[static_cast<std::size_t>(a)];
  run.center_b_m = spec.center[static_cast<std::size_t>(b)];
  run.metadata["machine"] = machine.config().name;
  std::ostringstream seed;
  seed << spec.seed;
  run.metadata["seed"] = seed.str();
  run.metadata["source"] = "guideway simulate dbb (virtual machine tool)";
  run.metadata["angle_source"] = "commanded";
  double t_start = -1;
  for (const auto& s : raw.samples) {
    if (!s.in_data_arc) continue;
    if (t_start < 0) t_start = s.t_s;
    run.t_s.push_back(s.t_s - t_start);
    run.angle_rad.push_back(s.angle_rad);
    run.dL_m.push_back(s.dL_m);
  }
  // Machine time of the first data sample: runs simulated on one machine clock (their spec.t0_s) share it.
  std::ostringstream start;
  start.precision(17);
  start << t_start;
  run.metadata["start_time_s"] = start.str();
  return run;
}

}  // namespace guideway::sim
