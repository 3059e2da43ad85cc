// The autocollimator traverse scenarios of EXPLAIN's suite: passes of the virtual machine's X carriage
// (600 mm, a reading every 10 mm, 2 s a station), forward and return, with one traverse error at a time, a
// pair, a null of several files, a coarse traverse of a dozen stations a pass, and a cause outside the
// library (the reflector is bumped part-way through a pass: a step in the readings).
#include <cmath>
#include <functional>
#include <numbers>
#include <stdexcept>

#include "models/explain/explain.hpp"
#include "models/explain/traverse_explain.hpp"
#include "results/parameters.hpp"
#include "simulators/machine/machine.hpp"
#include "simulators/scenarios/scenarios.hpp"

namespace guideway::simulators::scenarios {

namespace {

constexpr double arcsec = 4.84813681109536e-6;

struct TraverseScenario {
  std::string name, concealment;
  std::function<void(machine::MachineConfig&)> inject;
  std::vector<Expectation> expected;
  std::size_t passes = 2;  // forward, return, forward, ...
  std::size_t files = 1;
  double step_mm = 10.0;
  double bump_arcsec = 0.0;  // the reflector is bumped in the last pass, 40 % into it: the readings step
};

Expectation expect(const std::string& effect, const results::Parameter& p, double truth, double tolerance) {
  return {effect, results::name(p), truth, tolerance};
}

const std::vector<TraverseScenario>& traverse_scenarios() {
  static const std::vector<TraverseScenario> all = {
      {"traverse_drift",
       "the instrument drifts 0.2\"/min: 0.8\" over the forward and return passes, under a 14 urad pitch curve",
       [](machine::MachineConfig& m) { m.autocollimator.pitch_drift_rad_per_s = 0.2 * arcsec / 60.0; },
       {expect("angle_drift", results::angle_drift, 0.2, 0.02)}},
      {"traverse_rocking",
       "the reflector rocks 0.3\" with the direction of travel: a constant slope each way",
       [](machine::MachineConfig& m) { m.autocollimator.rocking_rad = 0.3 * arcsec; },
       {expect("reflector_rocking", results::reflector_rocking, 0.3, 0.02)}},
      {"traverse_pitch_wave",
       "the rack pitches the carriage 0.5\" every 75 mm (8 cycles over the traverse)",
       [](machine::MachineConfig& m) {
         m.axis[0].pitch_wave_rad = 0.5 * arcsec;
         m.axis[0].pitch_wave_period_m = 0.075;
         m.axis[0].pitch_wave_phase_rad = 0.7;
       },
       {expect("pitch_wave", results::pitch_wave, 0.5, 0.03)}},
      {"traverse_yaw_coupling",
       "the head is turned 3 deg about its beam: the pitch reads 5.2 % of a yaw with a 4\" wave every 120 mm",
       [](machine::MachineConfig& m) {
         m.axis[0].yaw_wave_rad = 4.0 * arcsec;
         m.axis[0].yaw_wave_period_m = 0.12;
         m.autocollimator.head_roll_rad = 3.0 * std::numbers::pi / 180.0;
       },
       {expect("yaw_coupling", results::yaw_coupling, 100.0 * std::sin(3.0 * std::numbers::pi / 180.0), 0.5)}},
      {"traverse_pair",
       "a drift of 0.15\"/min and a 0.3\" pitch wave every 50 mm, four passes",
       [](machine::MachineConfig& m) {
         m.autocollimator.pitch_drift_rad_per_s = 0.15 * arcsec / 60.0;
         m.axis[0].pitch_wave_rad = 0.3 * arcsec;
         m.axis[0].pitch_wave_period_m = 0.05;
       },
       {expect("angle_drift", results::angle_drift, 0.15, 0.015), expect("pitch_wave", results::pitch_wave, 0.3, 0.03)},
       4},
      {"traverse_few_stations",
       "the fewest readings a pass is tested on alone: 32 (18.75 mm steps), forward and return; the reflector rocks "
       "0.3\"",
       [](machine::MachineConfig& m) { m.autocollimator.rocking_rad = 0.3 * arcsec; },
       {expect("reflector_rocking", results::reflector_rocking, 0.3, 0.03)},
       2,
       1,
       18.75},
      {"traverse_null_files",
       "nothing left out: the pitch curve and 0.05\" noise, two set-ups of a forward and a return pass each",
       [](machine::MachineConfig&) {},
       {},
       2,
       2},
      {"traverse_bumped_reflector",
       "outside the library: the reflector is knocked 40 % into the return pass and reads 0.5\" more from there on",
       [](machine::MachineConfig&) {},
       {},
       2,
       1,
       10.0,
       0.5},
  };
  return all;
}

// The X carriage pitches along a smooth curve (12 urad of slope over 600 mm) and yaws a little; the
// autocollimator reads 0.05" of noise (config/machine-example.toml's [noise]).
machine::MachineConfig traverse_machine(std::uint64_t seed) {
  machine::MachineConfig m;
  m.name = "explain-traverse";
  m.axis[0].rotation[1].c = {0.0, -2e-5, 2.5e-8};
  m.axis[0].rotation[2].c = {0.0, 1e-5, -1e-8};
  m.noise.autocollimator_rad = 0.05 * arcsec;
  m.noise.seed = seed;
  return m;
}

}  // namespace

std::vector<models::explain::TraversePass> simulated_traverse(const machine::Machine& machine,
                                                              const SimulatedTraverse& t) {
  std::vector<models::explain::TraversePass> out;
  machine::TraverseSpec spec;
  // The mirror sits midway between the reflector's feet.
  spec.start_m = t.start_m + t.step_m / 2;
  spec.end_m = t.end_m - t.step_m / 2;
  spec.step_m = t.step_m;
  spec.dwell_s = t.dwell_s;
  for (std::size_t f = 0; f < t.files; ++f) {
    spec.seed = t.seed + f * 100;
    const auto passes = machine.autocollimator_passes(spec, t.passes, t.turn_s);
    for (std::size_t k = 0; k < passes.size(); ++k) {
      models::explain::TraversePass p;
      p.source = "simulated traverse" + (t.files > 1 ? " " + std::to_string(f + 1) : std::string()) + " pass " +
                 std::to_string(k + 1);
      p.file = f;
      p.direction = k % 2 == 0 ? 1 : -1;
      p.step_m = t.step_m;
      for (const auto& st : passes[k]) {
        p.x_m.push_back(st.position_m - t.step_m / 2);
        p.t_s.push_back(st.t_s);
        p.pitch_rad.push_back(-st.pitch_rad);
        p.yaw_rad.push_back(st.yaw_rad);
      }
      out.push_back(std::move(p));
    }
  }
  return out;
}

std::vector<std::string> traverse_scenario_names() {
  std::vector<std::string> out;
  for (const auto& s : traverse_scenarios()) out.push_back(s.name);
  return out;
}

ScenarioResult traverse_scenario(const std::string& name, const ScenarioOptions& o) {
  for (const auto& sc : traverse_scenarios()) {
    if (sc.name != name) continue;
    ScenarioResult s;
    s.name = sc.name;
    s.model = "traverse";
    s.concealment = sc.concealment;
    s.expected = sc.expected;
    s.expect_unexplained = sc.bump_arcsec != 0.0;
    machine::MachineConfig m = traverse_machine(o.seed);
    sc.inject(m);
    SimulatedTraverse t;
    t.step_m = sc.step_mm * 1e-3;
    t.passes = sc.passes;
    t.files = sc.files;
    t.seed = o.seed * 1000 + 500;
    auto passes = simulated_traverse(machine::Machine(m), t);
    if (sc.bump_arcsec != 0.0) {
      auto& last = passes.back().pitch_rad;
      for (std::size_t i = last.size() * 4 / 10; i < last.size(); ++i) last[i] += sc.bump_arcsec * arcsec;
    }
    s.report = models::explain::explain_traverses(passes, o.explain);
    check_expectations(s);
    return s;
  }
  throw std::invalid_argument("unknown scenario: " + name);
}

}  // namespace guideway::simulators::scenarios
