#pragma once
// DBB runs from the virtual machine tool, in the run-file form the identification reads (only the
// 360 deg data arc; overshoot arcs are dropped). Thread safe.

#include "formats/dbb_run.hpp"
#include "simulators/machine/machine.hpp"

namespace guideway::sim {

formats::DbbRun simulate_dbb_run(const Machine& machine, const DbbCircleSpec& spec, const std::string& source = "simulated");

}  // namespace guideway::sim
