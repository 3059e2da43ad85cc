// CPU of one `guideway explain --model dbb` against the samples per run (issue #29: linear in the samples):
// two runs (ccw, cw) of the scenario suite's virtual machine traced at 1,000 to 100,000 samples per run,
// for a machine with three effects at once, for nothing left out and for a fault outside the library (the
// ball slipping in its socket part-way through the first run). What is timed is the user's call,
// explain_dbb_report(runs): the problem built from the runs (geometry, drive tracks) and explained.
//
//   build/bench/explain_cost_bench --benchmark_counters_tabular=true
//
// "CPU" is the process CPU of one explain; samples_per_s = both runs' samples / CPU: flat when the cost is
// linear. bench/README.md ("EXPLAIN's cost") has the figures.
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "models/explain/dbb_explain.hpp"
#include "simulators/scenarios/scenarios.hpp"

namespace {

using namespace guideway;

void explain_cost(benchmark::State& state, const std::string& scenario) {
  const auto per_run = static_cast<double>(state.range(0));
  simulators::scenarios::ScenarioOptions o;
  o.samples_per_deg = per_run / 360.0;
  const std::vector<formats::DbbRun> runs = simulators::scenarios::scenario_dbb_runs(scenario, o);
  std::size_t samples = 0, findings = 0;
  bool unexplained = false;
  for (const auto& r : runs) samples += r.angle_rad.size();
  for (auto _ : state) {
    const models::explain::Report rep = models::explain::explain_dbb_report(runs);
    findings = rep.findings.size();
    unexplained = rep.unexplained;
    benchmark::DoNotOptimize(rep.final_fit.rms_um);
  }
  state.counters["samples"] = static_cast<double>(samples);
  state.counters["findings"] = static_cast<double>(findings);
  state.counters["unexplained"] = unexplained ? 1 : 0;
  state.counters["samples_per_s"] =
      benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsIterationInvariantRate);
}

void sizes(benchmark::internal::Benchmark* b) {
  for (const int n : {1000, 3600, 10000, 18000, 36000, 100000}) b->Arg(n);
  b->Unit(benchmark::kMillisecond)->Iterations(1);
}

BENCHMARK_CAPTURE(explain_cost, three_effects, std::string("dbb_three_backlash_vibration_drift"))->Apply(sizes);
BENCHMARK_CAPTURE(explain_cost, null, std::string("dbb_null"))->Apply(sizes);
BENCHMARK_CAPTURE(explain_cost, fault_ball_slip, std::string("dbb_ball_slip"))->Apply(sizes);

}  // namespace

BENCHMARK_MAIN();
