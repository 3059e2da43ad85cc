// The input files of bench/explain_footprint.py (bench/README.md "EXPLAIN's footprint"): the cases of issue 45's
// table, traced by the virtual machine tool, written as the files `guideway explain` and `guideway identify` read.
//
//   explain_footprint_cases OUT_DIR MACHINE_TOML
//
// OUT_DIR/<case>/ gets one file per run or record:
//   dbb_four       2 x 15,717 samples: X and Y backlash, a servo mismatch and a Y cyclic error (four findings;
//                  the scenario dbb_three_backlash_mismatch_cyclic at 1000 mm/min, 417 samples/s)
//   dbb_null_dense 2 x 37,709 samples: nothing left out (dbb_null at 1,000 samples/s)
//   dbb_slip_N     2 x N samples, N = 3,600 ... 36,000: X backlash 0.8 um beside the ball slipping 1 um in its
//                  socket at 100 deg of the first run (dbb_slip_beside_backlash); N = 18,859 is issue 45's case
//   runout_three   7,200 samples: the machine file's spindle (a 3-lobed race, a line at 3.7 per revolution,
//                  axial growth), 20 revolutions at 60 rpm, 360 samples a revolution
// The traverse case (a real profile as two passes) is written by explain_footprint.py from tests/data/dabam (entry 72).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numbers>
#include <string>
#include <vector>

#include "formats/dbb_run.hpp"
#include "simulators/machine/machine.hpp"
#include "simulators/scenarios/scenarios.hpp"

namespace {

using namespace guideway;

void write_dbb_case(const std::string& dir, const std::string& scenario, double samples_per_run) {
  simulators::scenarios::ScenarioOptions o;
  o.samples_per_deg = samples_per_run / 360.0;
  std::filesystem::create_directories(dir);
  const auto runs = simulators::scenarios::scenario_dbb_runs(scenario, o);
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const std::string path = dir + "/run" + std::to_string(k + 1) + ".csv";
    formats::write_dbb_run(runs[k], path);
    std::cout << path << ": " << runs[k].angle_rad.size() << " samples\n";
  }
}

void write_runout_case(const std::string& dir, const simulators::machine::Machine& machine) {
  simulators::machine::RunoutSpec spec;
  spec.rpm = 60.0;
  spec.samples_per_rev = 360;
  spec.revolutions = 20;
  spec.seed = 45;
  const auto samples = machine.runout_revolution(spec);
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/record.csv";
  std::ofstream out(path);
  out << "# plate_diameter_mm = 1000\n# parallelism_um = 2.5\n# rpm = 60\nangle_deg,runout_um\n";
  char line[64];
  for (const auto& s : samples) {
    std::snprintf(line, sizeof line, "%.17g,%.17g\n", s.angle_rad * 180.0 / std::numbers::pi, s.displacement_m * 1e6);
    out << line;
  }
  std::cout << path << ": " << samples.size() << " samples\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: explain_footprint_cases OUT_DIR MACHINE_TOML\n";
    return 2;
  }
  const std::string out = argv[1];
  write_dbb_case(out + "/dbb_four", "dbb_three_backlash_mismatch_cyclic", 15717);
  write_dbb_case(out + "/dbb_null_dense", "dbb_null", 37709);
  for (const int n : {3600, 7200, 18859, 36000})
    write_dbb_case(out + "/dbb_slip_" + std::to_string(n), "dbb_slip_beside_backlash", n);
  write_runout_case(out + "/runout_three",
                    simulators::machine::Machine(simulators::machine::load_machine_config(argv[2])));
  return 0;
}
