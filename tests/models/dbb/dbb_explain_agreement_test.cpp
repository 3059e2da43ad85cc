// The ballbar diagnostics (models/dbb identify) and EXPLAIN (models/explain) read the same runs with one
// physics: a deadband with its take-up is backlash in both and a reversal spike in neither, a stiction
// spike is a spike in both and backlash in neither, and both together are told apart alike. Each case is
// a CCW/CW pair of the virtual machine tool (commanded angles, as `guideway simulate dbb` writes), and the
// two outputs must agree within their expanded uncertainty (k = 2 of the combined standard uncertainty).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>
#include <string>

#include "dbb_test_support.hpp"
#include "models/explain/dbb_explain.hpp"

namespace {

using namespace guideway;

struct Value {
  double value = 0, u = 0;
};

// A CCW/CW pair (h = 0, r = 100 mm, 1000 mm/min, 10 samples per degree) of a machine with the given errors.
std::vector<formats::DbbRun> pair_of(const std::function<void(simulators::machine::MachineConfig&)>& set,
                                     std::uint64_t seed) {
  simulators::machine::MachineConfig cfg;
  cfg.dbb.noise_m = 0.1e-6;
  set(cfg);
  const simulators::machine::Machine m{cfg};
  std::vector<formats::DbbRun> runs;
  for (const bool ccw : {true, false}) {
    simulators::machine::DbbCircleSpec s;
    s.radius_m = 0.1;
    s.direction = ccw ? formats::DbbDirection::ccw : formats::DbbDirection::cw;
    s.seed = seed + (ccw ? 0 : 1);
    runs.push_back(simulators::machine::simulate_dbb_run(m, s, ccw ? "ccw" : "cw"));
  }
  return runs;
}

std::map<std::string, Value> explain_findings(const models::explain::Report& r) {
  std::map<std::string, Value> out;
  for (const auto& f : r.findings)
    for (const auto& p : f.parameters) out[p.name] = {p.value, p.u};
  return out;
}

bool took(const models::explain::Report& r, const std::string& effect) {
  for (const auto& f : r.findings)
    if (f.effect == effect) return true;
  return false;
}

struct Both {
  std::map<std::string, models::dbb::Estimate> diagnostics;
  std::map<std::string, Value> explain;
  models::explain::Report report;
};

Both both_of(const std::vector<formats::DbbRun>& runs) {
  Both b;
  b.diagnostics = test::by_name(models::dbb::identify(runs).diagnostics);
  b.report = models::explain::explain_dbb_report(runs);
  b.explain = explain_findings(b.report);
  return b;
}

// The diagnostic `name` agrees with EXPLAIN's value of it within k = 2 of their combined u.
void expect_agree(const Both& b, const std::string& name, double truth, const std::string& label) {
  ASSERT_TRUE(b.diagnostics.count(name)) << label << ": the diagnostics have no " << name;
  ASSERT_TRUE(b.explain.count(name)) << label << ": EXPLAIN found no " << name;
  const auto& d = b.diagnostics.at(name);
  const auto& e = b.explain.at(name);
  const double u = std::hypot(d.u, e.u);
  EXPECT_LE(std::abs(d.value - e.value), 2 * u) << label << ": " << name << " diagnostics " << d.value << " +/- " << d.u
                                                << ", EXPLAIN " << e.value << " +/- " << e.u;
  // And both are the machine's (within 3 u, or 3 %: EXPLAIN's u is conditional on its searched delay).
  for (const auto& [who, v] : {std::pair{"diagnostics", Value{d.value, d.u}}, std::pair{"EXPLAIN", e}})
    EXPECT_LE(std::abs(v.value - truth), std::max(3 * v.u, 0.03 * std::abs(truth)))
        << label << ": " << who << " " << name << " = " << v.value << " +/- " << v.u << ", machine " << truth;
}

// The diagnostic `name` is consistent with none (within 2 u), as EXPLAIN, which did not take `effect`.
void expect_none(const Both& b, const std::string& name, const std::string& effect, const std::string& label) {
  ASSERT_TRUE(b.diagnostics.count(name)) << label << ": the diagnostics have no " << name;
  const auto& d = b.diagnostics.at(name);
  EXPECT_LE(std::abs(d.value), 2 * d.u) << label << ": " << name << " = " << d.value << " +/- " << d.u
                                        << " on a machine without it";
  EXPECT_FALSE(took(b.report, effect)) << label << ": EXPLAIN took " << effect;
}

TEST(DbbExplainAgreementTest, DeadbandWithItsTakeUpIsBacklashAndNoSpike) {
  // Drives 30 ms behind the command: the play is taken up about 0.3 deg after each commanded reversal.
  const auto b = both_of(pair_of(
      [](simulators::machine::MachineConfig& c) {
        c.axis[0].backlash_m = 1.1e-6;
        c.axis[1].backlash_m = 0.7e-6;
        c.axis[0].servo_lag_s = c.axis[1].servo_lag_s = 0.03;
      },
      11));
  expect_agree(b, "backlash_x_um", 1.1, "deadband");
  expect_agree(b, "backlash_y_um", 0.7, "deadband");
  expect_none(b, "reversal_spike_x_um", "reversal_spike", "deadband");
  expect_none(b, "reversal_spike_y_um", "reversal_spike", "deadband");
}

TEST(DbbExplainAgreementTest, SpikesAloneAreSpikesAndNoBacklash) {
  const auto b = both_of(pair_of(
      [](simulators::machine::MachineConfig& c) {
        c.axis[0].reversal_spike_m = 3e-6;
        c.axis[1].reversal_spike_m = 2e-6;
      },
      21));
  expect_agree(b, "reversal_spike_x_um", 3.0, "spikes");
  expect_agree(b, "reversal_spike_y_um", 2.0, "spikes");
  expect_none(b, "backlash_x_um", "backlash", "spikes");
  expect_none(b, "backlash_y_um", "backlash", "spikes");
}

TEST(DbbExplainAgreementTest, DeadbandAndSpikesTogetherAreToldApart) {
  const auto b = both_of(pair_of(
      [](simulators::machine::MachineConfig& c) {
        c.axis[0].backlash_m = 1.1e-6;
        c.axis[1].backlash_m = 0.7e-6;
        c.axis[0].reversal_spike_m = 3e-6;
        c.axis[1].reversal_spike_m = 2e-6;
      },
      31));
  expect_agree(b, "backlash_x_um", 1.1, "both");
  expect_agree(b, "backlash_y_um", 0.7, "both");
  expect_agree(b, "reversal_spike_x_um", 3.0, "both");
  expect_agree(b, "reversal_spike_y_um", 2.0, "both");
}

}  // namespace
