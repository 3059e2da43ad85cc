// The virtual machine tool as the micrometer emulator's source (micrometer_machine_source.hpp): a thrust plate's run-
// out.
#include "simulators/emulators/micrometer_machine_source.hpp"

#include <cmath>
#include <stdexcept>

namespace guideway::simulators::emulators {

machine::RunoutSample RunoutMotion::at(double t_s) const {
  return machine.runout_sample(spec, static_cast<std::uint64_t>(std::floor(std::max(0.0, t_s) / sample_period_s)));
}

std::shared_ptr<const RunoutMotion> make_runout_motion(const machine::Machine& machine,
                                                       const machine::RunoutSpec& spec) {
  if (spec.samples_per_rev == 0 || !(spec.rpm > 0))
    throw std::invalid_argument("run-out motion: samples per revolution and rpm must be positive");
  auto m = std::make_shared<RunoutMotion>(RunoutMotion{machine, spec, 0.0});
  m->sample_period_s = 60.0 / spec.rpm / static_cast<double>(spec.samples_per_rev);
  return m;
}

MicrometerSource runout_motion_source(std::shared_ptr<const RunoutMotion> motion) {
  return [motion](double t_s) { return MicrometerPoint{motion->at(t_s).displacement_m}; };
}

machine::MachineConfig spindle_demo_machine_config() {
  machine::MachineConfig c;
  c.name = "spindle-demo";
  c.spindle.tilt_x_rad = 2.8e-6;
  c.spindle.plate_parallelism_rad = 2.5e-6;  // Mu: r = 0.3 um on a 1000 mm plate, p = 2.5 um
  c.spindle.axial_runout_m = 0.05e-6;
  c.axis[0].translation[2].c = {0.0, 0.0, 6e-4, -1.1e-2};  // E_ZX(x), metres: straightness in z of X
  c.noise.seed = 42;
  c.noise.micrometer_m = 0.01e-6;
  c.noise.profilometer_m = 0.02e-6;
  return c;
}

}  // namespace guideway::simulators::emulators
