// DBB identification speed: Lai's three patterns (Table 4), 3600 points each, from the virtual
// machine tool; the full identification (Lai third-order fit with its backlash refinement, the
// ballbar diagnostics with the spike and cyclic searches, ISO 230-4 figures).
#include <benchmark/benchmark.h>

#include "core/memory_policy.hpp"
#include "models/dbb/identify.hpp"
#include "simulators/machine/dbb_runs.hpp"

namespace {

using namespace guideway;

std::vector<guideway::formats::DbbRun> patterns() {
  simulators::machine::MachineConfig c;
  c.dbb.center_offset = {2e-6, 3e-6, 0};
  c.dbb.noise_m = 0.1e-6;
  c.axis[0].scale = -10e-6;
  c.axis[1].scale = 10e-6;
  c.axis[0].backlash_m = 1e-6;
  c.axis[1].backlash_m = 2e-6;
  c.axis[0].translation[1].c = {0, 3e-4, 2.25e-4, -5e-3};  // Lai's a_k in SI units
  c.axis[1].translation[2].c = {0, 1e-4, 1.5e-3, -1.5e-2};
  const simulators::machine::Machine m{c};
  std::vector<guideway::formats::DbbRun> runs;
  const struct {
    double r, h;
    guideway::formats::DbbDirection d;
  } spec[] = {
      {0.095, 0.031225, guideway::formats::DbbDirection::ccw}, {0.095, 0.031225, guideway::formats::DbbDirection::cw}, {0.1, 0.0, guideway::formats::DbbDirection::ccw}};
  std::uint64_t seed = 1;
  for (const auto& p : spec) {
    simulators::machine::DbbCircleSpec s;
    s.radius_m = p.r;
    s.height_m = p.h;
    s.direction = p.d;
    s.overshoot_rad = 0.5;
    s.seed = seed++;
    auto run = simulators::machine::simulate_dbb_run(m, s);
    // exactly 3600 points: drop the closing sample of the 360 deg arc
    run.t_s.resize(3600);
    run.angle_rad.resize(3600);
    run.dL_m.resize(3600);
    runs.push_back(std::move(run));
  }
  return runs;
}

void identify_loop(benchmark::State& state) {
  const auto runs = patterns();
  for (auto _ : state) {
    auto id = models::dbb::identify(runs);
    benchmark::DoNotOptimize(id);
  }
  state.SetItemsProcessed(state.iterations() * 3 * 3600);
}

// glibc's default policy: the MBs each identification frees go back to the kernel.
void BM_DbbIdentifyThreePatterns(benchmark::State& state) { identify_loop(state); }
BENCHMARK(BM_DbbIdentifyThreePatterns)->Unit(benchmark::kMillisecond)->Repetitions(9)->ReportAggregatesOnly(true);

// As guideway and guidewayd --analyse-session run it (core/memory_policy.hpp). Registered last: the policy is
// process-wide and stays set for whatever runs after it.
void BM_DbbIdentifyThreePatternsKeepFreedMemory(benchmark::State& state) {
  keep_freed_memory();
  identify_loop(state);
}
BENCHMARK(BM_DbbIdentifyThreePatternsKeepFreedMemory)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(9)
    ->ReportAggregatesOnly(true);

}  // namespace

BENCHMARK_MAIN();
