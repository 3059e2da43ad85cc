#pragma once
// Feeds the profilometer emulator from the virtual machine tool: every traverse is the faced
// workpiece's profile (guideway::simulators::machine::Machine::facing_profile) measured along the radius, traverse n
// drawing its noise with seed n + 1. Thread safe (the machine is immutable).

#include <memory>

#include "simulators/emulators/micrometer_machine_source.hpp"  // spindle_demo_machine_config()
#include "simulators/emulators/profilometer_emulator.hpp"
#include "simulators/machine/machine.hpp"

namespace guideway::simulators::emulators {

ProfileSource facing_profile_source(std::shared_ptr<const machine::Machine> machine, machine::FacingSpec spec);

// A 10 mm traverse at 1 um spacing across a face cut at 2 mm/min and 100 rpm (20 um feed marks).
machine::FacingSpec demo_facing_spec();

}  // namespace guideway::simulators::emulators
