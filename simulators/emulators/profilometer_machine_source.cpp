// The virtual machine tool as the profilometer's source (profilometer_machine_source.hpp): the faced workpiece along
// the radius.
#include "simulators/emulators/profilometer_machine_source.hpp"

namespace guideway::simulators::emulators {

ProfileSource facing_profile_source(std::shared_ptr<const machine::Machine> machine, machine::FacingSpec spec) {
  return [machine, spec](std::uint64_t traverse) {
    machine::FacingSpec s = spec;
    s.seed = traverse + 1;
    EmulatedProfile p;
    for (const machine::ProfilePoint& pt : machine->facing_profile(s)) {
      p.x_m.push_back(pt.x_m);
      p.z_m.push_back(pt.z_m);
    }
    return p;
  };
}

machine::FacingSpec demo_facing_spec() {
  machine::FacingSpec s;
  s.x_start_m = 0.050;
  s.x_end_m = 0.060;
  s.feed_m_per_s = 2.0 / 60000.0;
  s.spindle_rpm = 100.0;
  s.tool_nose_radius_m = 0.8e-3;
  s.profile_step_m = 1e-6;
  return s;
}

}  // namespace guideway::simulators::emulators
