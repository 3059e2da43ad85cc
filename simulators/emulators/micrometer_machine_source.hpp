#pragma once
// Feeds the micrometer emulator from the virtual machine tool: a probe on a thrust plate fixed to
// the spindle face sees the plate's run-out (guideway::simulators::machine::Machine::runout_sample), an
// endless record in emulator time, sample-and-hold between the model's samples (so thermal growth and
// asynchronous lines run on instead of repeating). Thread safe (immutable).

#include <memory>

#include "simulators/emulators/modbus_emulator.hpp"
#include "simulators/machine/machine.hpp"

namespace guideway::simulators::emulators {

struct RunoutMotion {
  machine::Machine machine;
  machine::RunoutSpec spec;  // rpm, probe radius and samples_per_rev of the model's samples
  double sample_period_s = 0.0;
  // The model sample the probe shows at emulator time t.
  [[nodiscard]] machine::RunoutSample at(double t_s) const;
};
std::shared_ptr<const RunoutMotion> make_runout_motion(const machine::Machine& machine,
                                                       const machine::RunoutSpec& spec);
MicrometerSource runout_motion_source(std::shared_ptr<const RunoutMotion> motion);

// A machine whose spindle has the errors a run-out test shows (spindle lean, run-out plate
// parallelism, axial run-out) and an X axis with straightness in z, for a faced profile; used when no
// machine file is given.
machine::MachineConfig spindle_demo_machine_config();

}  // namespace guideway::simulators::emulators
