// The held-out RMS of `guideway explain` measured two ways on the scenario suite (docs/explain.md
// "Held out"): with every effect's variant chosen again inside each fold from its training rows (nested,
// what explain reports) and with the variants chosen on all the data kept (optimistic: the held-out
// rows took part in the choice). Prints, per scenario and seed, the held-out RMS before and after both
// ways, whether the findings differ, and the CPU time of each explain.
//
//   explain_heldout_bench [--full] [--seeds N]
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "simulators/scenarios/scenarios.hpp"

using namespace guideway;

namespace {

std::string effects(const models::explain::Report& r) {
  std::string s;
  for (const auto& f : r.findings) s += (s.empty() ? "" : "+") + f.effect;
  return s.empty() ? "none" : s;
}

}  // namespace

int main(int argc, char** argv) {
  bool full = false;
  int seeds = 3;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--full") full = true;
    else if (a == "--seeds" && i + 1 < argc) seeds = std::atoi(argv[++i]);
    else {
      std::fprintf(stderr, "usage: explain_heldout_bench [--full] [--seeds N]\n");
      return 2;
    }
  }
  std::printf("| scenario | seed | held-out before (um) | after, variants fixed | after, nested | findings fixed / nested | "
              "CPU fixed / nested (s) |\n|---|---|---|---|---|---|---|\n");
  double cpu[2] = {0, 0};
  int changed = 0, runs = 0;
  for (const auto& name : simulators::scenarios::scenario_names()) {
    for (int seed = 1; seed <= seeds; ++seed) {
      simulators::scenarios::ScenarioResult res[2];
      double t[2];
      for (int k = 0; k < 2; ++k) {
        simulators::scenarios::ScenarioOptions o;
        o.quick = !full;
        o.seed = static_cast<std::uint64_t>(seed);
        o.explain.heldout_reselect = k == 1;
        const std::clock_t c0 = std::clock();
        res[k] = simulators::scenarios::run_scenario(name, o);
        t[k] = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
        cpu[k] += t[k];
      }
      const std::string f0 = effects(res[0].report), f1 = effects(res[1].report);
      changed += f0 != f1;
      ++runs;
      std::printf("| %s | %d | %.6f | %.6f | %.6f | %s / %s%s | %.2f / %.2f |\n", name.c_str(), seed,
                  res[1].report.baseline.heldout_rms_um, res[0].report.final_fit.heldout_rms_um,
                  res[1].report.final_fit.heldout_rms_um, f0.c_str(), f1.c_str(), f0 != f1 ? " (CHANGED)" : "", t[0], t[1]);
    }
  }
  std::printf("\n%d of %d runs changed their findings; CPU total %.2f s (variants fixed) vs %.2f s (nested), %s density\n",
              changed, runs, cpu[0], cpu[1], full ? "full" : "quick");
  return 0;
}
