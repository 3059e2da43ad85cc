// The spindle run-out scenarios of EXPLAIN's suite: records of the virtual machine's spindle (20
// revolutions at 60 rpm, as the runout session takes them by default) with one error motion at a time,
// a pair, a reversal (two records, the plate turned 180 deg between them), a null of several records,
// and a cause outside the library (the probe slips on the plate).
#include <cmath>
#include <functional>
#include <numbers>
#include <stdexcept>

#include "models/explain/explain.hpp"
#include "models/explain/runout_explain.hpp"
#include "results/parameters.hpp"
#include "simulators/machine/machine.hpp"
#include "simulators/scenarios/scenarios.hpp"

namespace guideway::simulators::scenarios {

namespace {

constexpr double um = 1e-6;

struct RunoutScenario {
  std::string name, concealment;
  std::function<void(machine::MachineConfig&)> inject;
  std::vector<Expectation> expected;
  std::size_t records = 1;
  double slip_um = 0.0;  // the probe slips on the plate 60 % into each record: a step of the reading
  // Donaldson's reversal: the plate turned by this much in every record after the first, the records'
  // angles from the spindle's zero (0: each record's angle from its own first reading).
  double turned_deg = 0.0;
};

Expectation expect(const std::string& effect, const results::Parameter& p, double truth, double tolerance) {
  return {effect, results::name(p), truth, tolerance};
}

// The readings see the spindle's motion along +z with its sign reversed (the plate's height under the
// probe): a growth of g um/min reads -g.
const std::vector<RunoutScenario>& runout_scenarios() {
  static const std::vector<RunoutScenario> all = {
      {"runout_harmonic",
       "a 4-lobed race, 0.03 um, under a 0.15 um once-per-revolution lean and 0.01 um noise",
       [](machine::MachineConfig& m) {
         m.spindle.synchronous = {{4, 0.03 * um, 0.5}};
       },
       {expect("synchronous_harmonic", results::synchronous_harmonic, 0.03, 0.003)}},
      {"runout_async_line",
       "a bearing defect at 2.3 per revolution, 0.03 um: no revolution repeats it",
       [](machine::MachineConfig& m) {
         m.spindle.asynchronous = {{2.3, 0.03 * um, 1.0}};
       },
       {expect("asynchronous_line", results::asynchronous_line, 0.03, 0.003)}},
      {"runout_growth",
       "axial growth 0.2 um/min: 0.07 um over the 20 s record, a slow trend beside the lean",
       [](machine::MachineConfig& m) { m.spindle.axial_growth_m_per_s = 0.2 * um / 60.0; },
       {expect("thermal_drift", results::axial_growth, -0.2, 0.02)}},
      {"runout_speed_ramp",
       "the speed rises 2 %/min: the lean's phase slides by 8 deg over the record",
       [](machine::MachineConfig& m) { m.spindle.speed_ramp_per_s = 0.02 / 60.0; },
       {expect("speed_variation", results::speed_ramp, 2.0, 0.3)}},
      {"runout_pair",
       "a 3rd harmonic 0.1 um and a line at 3.7 per revolution 0.05 um: 0.7 of an order apart",
       [](machine::MachineConfig& m) {
         m.spindle.synchronous = {{3, 0.1 * um, 0.0}};
         m.spindle.asynchronous = {{3.7, 0.05 * um, 2.0}};
       },
       {expect("synchronous_harmonic", results::synchronous_harmonic, 0.1, 0.003),
        expect("asynchronous_line", results::asynchronous_line, 0.05, 0.003)}},
      {"runout_reversal",
       "a 3-lobed race 0.08 um under a plate of 3 lobes 0.05 um: one 3rd harmonic in a record; two records, the "
       "plate turned 180 deg (Donaldson)",
       [](machine::MachineConfig& m) {
         m.spindle.synchronous = {{3, 0.08 * um, 0.3}};
         m.spindle.plate_form = {{3, 0.05 * um, 1.2}};
       },
       {expect("synchronous_harmonic", results::synchronous_harmonic, 0.08, 0.006),
        expect("artifact_form", results::artifact_form, 0.05, 0.006)},
       2,
       0.0,
       180.0},
      {"runout_speed_ripple",
       "the speed ripples 1 % at 0.4 per revolution (a drive) under a 1 um lean: the lean's phase wobbles 1.4 deg",
       [](machine::MachineConfig& m) {
         m.spindle.plate_parallelism_rad = 0.8e-6;
         m.spindle.speed_ripple = 0.01;
         m.spindle.speed_ripple_per_rev = 0.4;
       },
       {expect("speed_ripple", results::speed_ripple, 1.0, 0.15)}},
      {"runout_null_records",
       "nothing left out: the lean and 0.01 um noise, three records each from its own angle",
       [](machine::MachineConfig&) {},
       {},
       3},
      {"runout_probe_slip",
       "outside the library: the probe slips 0.04 um on the plate 60 % into the record",
       [](machine::MachineConfig&) {},
       {},
       1,
       0.04},
  };
  return all;
}

// The lean (2.8 urad) against a plate leaning 2.5 urad, probe at 500 mm: 0.15 um once per revolution.
machine::MachineConfig spindle_machine(std::uint64_t seed) {
  machine::MachineConfig m;
  m.name = "explain-spindle";
  m.spindle.tilt_x_rad = 2.8e-6;
  m.spindle.plate_parallelism_rad = 2.5e-6;
  m.noise.micrometer_m = 0.01 * um;
  m.noise.seed = seed;
  return m;
}

std::vector<models::explain::RunoutRecord> records(const machine::Machine& machine, const RunoutScenario& sc,
                                                   const ScenarioOptions& o) {
  std::vector<models::explain::RunoutRecord> out;
  for (std::size_t k = 0; k < sc.records; ++k) {
    machine::RunoutSpec spec;
    spec.rpm = 60.0;
    spec.samples_per_rev = o.quick ? 50 : 100;  // 50: the session's 50 Hz polling; 100: a faster amplifier
    spec.revolutions = 20;
    spec.seed = o.seed * 1000 + 300 + k;
    spec.artifact_turned_rad = static_cast<double>(k) * sc.turned_deg * std::numbers::pi / 180.0;
    const auto samples = machine.runout_revolution(spec);
    models::explain::RunoutRecord r;
    r.source = "scenario-runout" + std::to_string(k + 1);
    r.rpm = spec.rpm;
    if (sc.turned_deg != 0) r.artifact_turned_rad = spec.artifact_turned_rad;
    // Each record starts where the spindle happens to be: its angle counts from its first reading. A
    // reversal's records start at the spindle's zero (an index triggers them).
    r.angle_from_spindle_zero = sc.turned_deg != 0;
    const std::size_t skip = sc.turned_deg != 0 ? 0 : k * 7;
    for (std::size_t i = skip; i < samples.size(); ++i) {
      const double t = samples[i].t_s - samples[skip].t_s;
      r.angle_rad.push_back(2 * std::numbers::pi * spec.rpm / 60.0 * t);
      const bool slipped = sc.slip_um != 0.0 && i >= skip + (samples.size() - skip) * 6 / 10;
      r.runout_m.push_back(samples[i].displacement_m + (slipped ? sc.slip_um * um : 0.0));
    }
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace

std::vector<std::string> runout_scenario_names() {
  std::vector<std::string> out;
  for (const auto& s : runout_scenarios()) out.push_back(s.name);
  return out;
}

ScenarioResult runout_scenario(const std::string& name, const ScenarioOptions& o) {
  for (const auto& sc : runout_scenarios()) {
    if (sc.name != name) continue;
    ScenarioResult s;
    s.name = sc.name;
    s.model = "runout";
    s.concealment = sc.concealment;
    s.expected = sc.expected;
    s.expect_unexplained = sc.slip_um != 0.0;
    machine::MachineConfig m = spindle_machine(o.seed);
    sc.inject(m);
    s.report =
        models::explain::explain(models::explain::runout_problem(records(machine::Machine(m), sc, o)), o.explain);
    check_expectations(s);
    return s;
  }
  throw std::invalid_argument("unknown scenario: " + name);
}

}  // namespace guideway::simulators::scenarios
