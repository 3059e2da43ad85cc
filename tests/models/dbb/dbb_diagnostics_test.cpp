// Ballbar diagnostics recovered from runs of the virtual machine tool: each error alone and all
// together, both directions (within 5 % or 2 u); the sign conventions of docs/conventions.md.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>

#include "dbb_test_support.hpp"

namespace {

using namespace guideway;

struct Expect {
  const char* name;
  double value;
};

// A ccw/cw pair (h = 0, r = 100 mm, 1000 mm/min) from a machine with the given errors.
models::dbb::Identification run_pair(const simulators::machine::MachineConfig& cfg, std::uint64_t seed,
                                     double noise_um = 0.1, double rate_hz = 0) {
  simulators::machine::MachineConfig c = cfg;
  c.dbb.noise_m = noise_um * 1e-6;
  const simulators::machine::Machine m{c};
  std::vector<guideway::formats::DbbRun> runs;
  for (bool ccw : {true, false}) {
    simulators::machine::DbbCircleSpec s;
    s.radius_m = 0.1;
    s.direction = ccw ? guideway::formats::DbbDirection::ccw : guideway::formats::DbbDirection::cw;
    s.seed = seed + (ccw ? 0 : 1);
    s.sample_rate_hz = rate_hz;
    runs.push_back(simulators::machine::simulate_dbb_run(m, s, ccw ? "ccw" : "cw"));
  }
  return models::dbb::identify(runs);
}

void check(const models::dbb::Identification& id, const std::vector<Expect>& expects, const std::string& label) {
  const auto est = test::by_name(id.diagnostics);
  for (const auto& e : expects) {
    ASSERT_TRUE(est.count(e.name)) << label << ": " << e.name << " missing; " << id.diagnostics_fit.message;
    const auto& x = est.at(e.name);
    const double tol = std::max(0.05 * std::abs(e.value), 2.0 * (std::isfinite(x.u) ? x.u : 0.0));
    EXPECT_LE(std::abs(x.value - e.value), tol)
        << label << ": " << e.name << " = " << x.value << " +/- " << x.u << ", expected " << e.value;
  }
}

struct Case {
  const char* label;
  std::function<void(simulators::machine::MachineConfig&)> set;
  std::vector<Expect> expect;
};

std::vector<Case> single_cases() {
  return {
      {"center offset",
       [](simulators::machine::MachineConfig& c) {
         c.dbb.center_offset = {5e-6, -3e-6, 0};
       },
       {{"run1.center_offset_x_um", 5.0}, {"run1.center_offset_y_um", -3.0}, {"run2.center_offset_x_um", 5.0}}},
      {"scale",
       [](simulators::machine::MachineConfig& c) {
         c.axis[0].scale = 20e-6;
         c.axis[1].scale = -15e-6;
       },
       {{"scale_x_ppm", 20.0}, {"scale_y_ppm", -15.0}, {"scale_mismatch_ppm", 35.0}}},
      {"squareness",
       [](simulators::machine::MachineConfig& c) { c.squareness.xy = 50e-6; },
       {{"squareness_urad", 50.0}}},
      {"backlash",
       [](simulators::machine::MachineConfig& c) {
         c.axis[0].backlash_m = 4e-6;
         c.axis[1].backlash_m = 6e-6;
       },
       {{"backlash_x_um", 4.0}, {"backlash_y_um", 6.0}}},
      {"lateral play",
       [](simulators::machine::MachineConfig& c) {
         c.axis[0].lateral_play_m = 3e-6;
         c.axis[1].lateral_play_m = 2e-6;
       },
       {{"lateral_play_x_um", 3.0}, {"lateral_play_y_um", 2.0}}},
      {"reversal spikes",
       [](simulators::machine::MachineConfig& c) {
         c.axis[0].reversal_spike_m = 6e-6;
         c.axis[1].reversal_spike_m = 4e-6;
       },
       {{"reversal_spike_x_um", 6.0}, {"reversal_spike_y_um", 4.0}}},
      {"servo mismatch",
       [](simulators::machine::MachineConfig& c) {
         c.axis[0].servo_lag_s = 0.004;
         c.axis[1].servo_lag_s = 0.003;
       },
       {{"servo_mismatch_ms", 1.0}}},
      {"cyclic",
       [](simulators::machine::MachineConfig& c) {
         c.axis[0].cyclic_amplitude_m = 1.5e-6;
         c.axis[0].cyclic_period_m = 0.005;
         c.axis[0].cyclic_phase_rad = 0.7;
         c.axis[1].cyclic_amplitude_m = 1.0e-6;
         c.axis[1].cyclic_period_m = 0.010;
       },
       {{"cyclic_error_x_um", 1.5},
        {"cyclic_period_x_mm", 5.0},
        {"cyclic_phase_x_deg", 0.7 * 180 / std::numbers::pi},
        {"cyclic_error_y_um", 1.0},
        {"cyclic_period_y_mm", 10.0}}},
      {"straightness",
       [](simulators::machine::MachineConfig& c) {
         c.axis[0].translation[1].c = {0, 0, 3e-4};   // 3 um bow over +/-100 mm
         c.axis[1].translation[0].c = {0, 0, -2e-4};  // -2 um
       },
       {{"straightness_x_um", 3.0}, {"straightness_y_um", -2.0}}},
  };
}

TEST(DbbDiagnosticsTest, EachErrorAloneIsRecovered) {
  std::uint64_t seed = 100;
  for (const auto& c : single_cases()) {
    simulators::machine::MachineConfig cfg;
    c.set(cfg);
    const auto id = run_pair(cfg, seed += 2);
    check(id, c.expect, c.label);
  }
}

TEST(DbbDiagnosticsTest, AllErrorsTogetherAreRecovered) {
  simulators::machine::MachineConfig cfg;
  std::vector<Expect> all;
  for (const auto& c : single_cases()) {
    c.set(cfg);
    all.insert(all.end(), c.expect.begin(), c.expect.end());
  }
  // Sampled at 1 kHz like a commercial ballbar: the spikes start one servo lag after the commanded
  // reversal, and only a sample spacing shorter than the lag lets the fit see that delay.
  const auto id = run_pair(cfg, 900, 0.1, 1000.0);
  check(id, all, "all together");
}

TEST(DbbDiagnosticsTest, EachErrorAloneFromASingleRunInEitherDirection) {
  // One run, ccw or cw: everything but squareness/servo mismatch (which need both directions).
  std::uint64_t seed = 300;
  for (bool ccw : {true, false}) {
    for (const auto& c : single_cases()) {
      const std::string label = std::string(c.label) + (ccw ? " (ccw only)" : " (cw only)");
      if (std::string(c.label) == "squareness" || std::string(c.label) == "servo mismatch") continue;
      simulators::machine::MachineConfig cfg;
      c.set(cfg);
      cfg.dbb.noise_m = 0.1e-6;
      const simulators::machine::Machine m{cfg};
      simulators::machine::DbbCircleSpec s;
      s.radius_m = 0.1;
      s.direction = ccw ? guideway::formats::DbbDirection::ccw : guideway::formats::DbbDirection::cw;
      s.seed = ++seed;
      const auto id = models::dbb::identify({simulators::machine::simulate_dbb_run(m, s, label)});
      std::vector<Expect> expect;
      for (const auto& e : c.expect)
        if (std::string(e.name).rfind("run2.", 0) == 0)
          continue;
        else if (std::string(e.name).rfind("run1.", 0) == 0)
          expect.push_back({e.name + 5, e.value});
        else
          expect.push_back(e);
      check(id, expect, label);
    }
  }
}

TEST(DbbDiagnosticsTest, SingleDirectionRefusesToSeparateSquarenessFromServoMismatch) {
  simulators::machine::MachineConfig cfg;
  cfg.squareness.xy = 50e-6;
  const simulators::machine::Machine m{cfg};
  simulators::machine::DbbCircleSpec s;
  s.radius_m = 0.1;
  const auto id = models::dbb::identify({simulators::machine::simulate_dbb_run(m, s, "ccw")});
  const auto& u = id.diagnostics_fit.unidentifiable;
  EXPECT_NE(std::find(u.begin(), u.end(), "squareness_urad"), u.end());
  EXPECT_NE(std::find(u.begin(), u.end(), "servo_mismatch_ms"), u.end());
  const auto est = test::by_name(id.diagnostics);
  EXPECT_EQ(est.count("squareness_urad"), 0u);
  EXPECT_EQ(est.count("servo_mismatch_ms"), 0u);
  EXPECT_EQ(est.count("scale_x_ppm"), 1u);
}

TEST(DbbDiagnosticsTest, CircularDeviationAndHysteresis) {
  // Backlash alone: each run is a circle with steps of b/2 at the reversals of each axis; the two
  // directions differ by the full backlash at the reversals.
  simulators::machine::MachineConfig cfg;
  cfg.axis[0].backlash_m = 4e-6;
  const auto id = run_pair(cfg, 5, 0.0);
  const auto est = test::by_name(id.diagnostics);
  ASSERT_TRUE(est.count("circular_hysteresis_um"));
  EXPECT_NEAR(est.at("circular_hysteresis_um").value, 4.0, 0.3);
  ASSERT_TRUE(est.count("circular_deviation_um"));
  EXPECT_GT(est.at("circular_deviation_um").value, 1.5);
  EXPECT_LT(est.at("circular_deviation_um").value, 4.5);
  // A perfect machine: G and H are the noise.
  const auto perfect = run_pair(simulators::machine::MachineConfig{}, 6, 0.0);
  EXPECT_LT(test::by_name(perfect.diagnostics).at("circular_deviation_um").value, 1e-6);
}

// ---- sign conventions (docs/conventions.md), checked on the raw signal and on the estimate ----

guideway::formats::DbbRun one(const simulators::machine::MachineConfig& cfg, bool ccw) {
  const simulators::machine::Machine m{cfg};
  simulators::machine::DbbCircleSpec s;
  s.radius_m = 0.1;
  s.direction = ccw ? guideway::formats::DbbDirection::ccw : guideway::formats::DbbDirection::cw;
  return simulators::machine::simulate_dbb_run(m, s, "conv");
}

double dl_at(const guideway::formats::DbbRun& r, double zeta_deg) {
  double best = 1e9, val = 0;
  for (std::size_t i = 0; i < r.angle_rad.size(); ++i) {
    double d = std::fmod(std::abs(r.angle_rad[i] * 180 / std::numbers::pi - zeta_deg), 360.0);
    d = std::min(d, 360 - d);
    if (d < best) {
      best = d;
      val = r.dL_m[i];
    }
  }
  return val;
}

TEST(DbbConventionsTest, CenterOffsetIsTheCircleCentreRelativeToTheFixedBall) {
  simulators::machine::MachineConfig c;
  c.dbb.center_offset = {5e-6, 0, 0};  // circle centre 5 um towards +x of the fixed ball
  const auto r = one(c, true);
  EXPECT_NEAR(dl_at(r, 0), 5e-6, 1e-8);  // longest at zeta = 0
  EXPECT_NEAR(dl_at(r, 180), -5e-6, 1e-8);
}

TEST(DbbConventionsTest, ScaleIsPositiveWhenTheAxisTravelsTooFar) {
  simulators::machine::MachineConfig c;
  c.axis[1].scale = 20e-6;
  const auto r = one(c, true);
  EXPECT_NEAR(dl_at(r, 90), 0.1 * 20e-6, 1e-9);
  EXPECT_NEAR(dl_at(r, 0), 0.0, 1e-9);
}

TEST(DbbConventionsTest, PositiveSquarenessIsLongestOnThe45DegreeDiagonal) {
  simulators::machine::MachineConfig c;
  c.squareness.xy = 100e-6;
  const auto r = one(c, true);
  EXPECT_NEAR(dl_at(r, 45), 0.1 * 100e-6 * 0.5, 2e-9);
  EXPECT_NEAR(dl_at(r, 225), 0.1 * 100e-6 * 0.5, 2e-9);
  EXPECT_NEAR(dl_at(r, 135), -0.1 * 100e-6 * 0.5, 2e-9);
}

TEST(DbbConventionsTest, BacklashLosesHalfTheMotionAgainstTheDirectionOfTravel) {
  simulators::machine::MachineConfig c;
  c.axis[0].backlash_m = 4e-6;
  // actual x = commanded x - (b/2) sign(dx/dt). ccw at 135 deg x decreases: actual x = commanded + b/2,
  // dL = (b/2) cos 135 deg < 0; at 315 deg x increases: actual = commanded - b/2, dL = -(b/2) cos 315 < 0.
  const double half = 2e-6, c45 = std::sqrt(0.5);
  const auto r = one(c, true);
  EXPECT_NEAR(dl_at(r, 135), -half * c45, 1e-9);
  EXPECT_NEAR(dl_at(r, 315), -half * c45, 1e-9);
  EXPECT_NEAR(dl_at(r, 45), half * c45, 1e-9);  // x decreasing, cos > 0
  const auto cw = one(c, false);
  EXPECT_NEAR(dl_at(cw, 135), half * c45, 1e-9);
}

TEST(DbbConventionsTest, ServoMismatchSignFlipsWithDirection) {
  simulators::machine::MachineConfig c;
  c.axis[0].servo_lag_s = 0.002;  // x lags 1 ms more than y
  c.axis[1].servo_lag_s = 0.001;
  const double v = 1000.0 / 60000.0, dtau = 0.001;
  const auto ccw = one(c, true);
  const auto cw = one(c, false);
  // (v dtau / 2) sin 2 zeta for ccw, opposite for cw (plus a tiny common radius reduction)
  const double expected = v * dtau / 2;
  EXPECT_NEAR(dl_at(ccw, 45) - dl_at(ccw, 135), 2 * expected, 0.02 * expected);
  EXPECT_NEAR(dl_at(cw, 45) - dl_at(cw, 135), -2 * expected, 0.02 * expected);
}

TEST(DbbConventionsTest, CyclicErrorFollowsTheAxisPosition) {
  simulators::machine::MachineConfig c;
  c.axis[0].cyclic_amplitude_m = 1e-6;
  c.axis[0].cyclic_period_m = 0.004;
  const simulators::machine::Machine m{c};
  // actual x = x + A sin(2 pi x / p): at x = 1 mm (a quarter period) the tool is 1 um further out.
  const auto motion =
      m.simulate_motion({simulators::machine::linear_move({0, 0, 0}, {0.001, 0, 0}, 0.001), 1.5, 100.0});
  EXPECT_NEAR(motion.back().tool[0], 0.001 + 1e-6, 1e-9);
}

}  // namespace
