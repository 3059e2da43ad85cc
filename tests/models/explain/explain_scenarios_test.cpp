// The EXPLAIN scenario suite (simulators/scenarios/scenarios.cpp) at quick sample density: every scenario
// must meet its own expectation (right effect first, parameter within tolerance of the truth,
// held-out RMS improved; nothing found on noise; an out-of-library bump located, not attributed).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include "models/explain/dbb_explain.hpp"
#include "simulators/machine/dbb_runs.hpp"
#include "simulators/machine/machine.hpp"
#include "simulators/scenarios/scenarios.hpp"
#include "sanitizer_build.hpp"

using namespace guideway;

class ExplainScenario : public ::testing::TestWithParam<std::string> {};

TEST_P(ExplainScenario, MeetsItsExpectation) {
  const auto r = simulators::scenarios::run_scenario(GetParam());
  EXPECT_TRUE(r.pass) << r.name << ": " << r.failure << "\n" << models::explain::to_text(r.report);
  // Every injected effect is found, and nothing else.
  ASSERT_EQ(r.checks.size(), r.expected.size());
  for (const auto& c : r.checks)
    EXPECT_TRUE(c.found && c.within) << r.name << ": " << c.expected.parameter << " = " << c.value;
  EXPECT_TRUE(r.extra.empty()) << r.name;
  if (!r.expected.empty()) {
    EXPECT_LT(r.report.final_fit.heldout_rms_um, r.report.baseline.heldout_rms_um);
  } else {
    EXPECT_TRUE(r.report.findings.empty()) << r.name;
  }
  EXPECT_EQ(r.report.unexplained, r.expect_unexplained);
  // DBB findings come ranked against the runs' circular deviation G: each one's part of it, in um and %.
  if (r.model == "dbb") {
    EXPECT_GT(r.report.deviation_um, 0.0);
    for (const auto& f : r.report.findings) {
      EXPECT_GT(f.contribution_um, 0.0) << f.effect;
      EXPECT_NEAR(f.contribution_percent, 100 * f.contribution_um / r.report.deviation_um, 1e-9) << f.effect;
    }
  }
}

// A finding's part of G is the range of its term about the least-squares circle: a backlash of b on X
// alone gives steps of b/2 at the X reversals, a range of about b about the circle (here 0.5 um).
TEST(ExplainScenarios, BacklashPartOfTheCircularDeviationIsItsWidth) {
  const auto r = simulators::scenarios::run_scenario("dbb_backlash");
  ASSERT_EQ(r.report.findings.size(), 1u);
  const auto& f = r.report.findings.front();
  EXPECT_NEAR(f.contribution_um, r.checks.front().value, 0.1 * r.checks.front().value);
}

std::string scenario_name(const ::testing::TestParamInfo<std::string>& p) { return p.param; }

INSTANTIATE_TEST_SUITE_P(All, ExplainScenario, ::testing::ValuesIn(simulators::scenarios::scenario_names()),
                         scenario_name);

// The reported uncertainties are honest: over seeds 1-5 of the scenarios with several effects, the errors
// against the truth fall within 1 u and 2 u about as often as a Gaussian's (68 %, 95 %): not too seldom
// (u too small) nor always (u too large). (Full density, seeds 1-5, every scenario: 69 % and 93 % of 240,
// the table in docs/explain.md.)
TEST(ExplainScenarios, UncertaintiesCoverTheTruthOverSeeds) {
#if defined(GUIDEWAY_SANITIZED_ADDRESS)
  // Statistics: the scenarios of MeetsItsExpectation again over five seeds, the same code with other
  // random numbers; ten times slower under ASan (two minutes of the stage) for no memory-safety
  // coverage the per-scenario cases lack. The Release stage runs it.
  GTEST_SKIP() << "a statistical test over seeds: run in the Release build, not under ASan";
#endif
  std::vector<simulators::scenarios::ScenarioSummary> sums;
  for (const auto& name : simulators::scenarios::scenario_names())
    if (name.rfind("dbb_pair_", 0) == 0 || name.rfind("dbb_three_", 0) == 0 || name == "dbb_centre_drift")
      sums.push_back(simulators::scenarios::summarize_scenario(name, {1, 2, 3, 4, 5}));
  const simulators::scenarios::Coverage c = simulators::scenarios::uncertainty_coverage(sums);
  EXPECT_GE(c.n, 100u);
  EXPECT_GE(c.within_1u, 0.55) << c.within_1u;
  EXPECT_LE(c.within_1u, 0.85) << c.within_1u;
  EXPECT_GE(c.within_2u, 0.85) << c.within_2u;
  for (const auto& s : sums) EXPECT_EQ(s.passed, s.runs.size()) << s.name;
}

TEST(ExplainScenarios, UnknownNameIsAnError) {
  EXPECT_THROW((void)simulators::scenarios::run_scenario("nope"), std::invalid_argument);
}

// The out-of-library scenario's cause: the machine's local guideway bump (simulators/machine).
TEST(ExplainScenarios, MachineBumpIsLocalAndReadFromToml) {
  const auto cfg = simulators::machine::parse_machine_config(
      "[axis.x]\nbump_um = 2.0\nbump_center_mm = 60\nbump_width_mm = 5\nbump_direction = \"y\"\n", "bump.toml");
  EXPECT_DOUBLE_EQ(cfg.axis[0].bump_amplitude_m, 2e-6);
  EXPECT_EQ(cfg.axis[0].bump_direction, 1);
  const simulators::machine::Machine m(cfg);
  const auto at = [&](double x_m) { return m.tool_point({x_m, 0.0, 0.0}); };
  EXPECT_NEAR(at(0.060)[1], 2e-6, 1e-12);
  EXPECT_NEAR(at(0.065)[1], 2e-6 * std::exp(-0.5), 1e-12);
  EXPECT_NEAR(at(0.0)[1], 0.0, 1e-15);
  EXPECT_NEAR(at(0.060)[0], 0.060, 1e-12);  // not along the axis itself
  EXPECT_THROW((void)simulators::machine::parse_machine_config("[axis.x]\nbump_direction = \"w\"\n", "bad.toml"),
               std::exception);
}

// The spindle run-out scenario's cause: FacingSpec::runout_along_path adds the spindle's axial motion
// at the moment of the cut; off, the profile is unchanged.
TEST(ExplainScenarios, FacingRunoutAlongPathIsOptIn) {
  simulators::machine::MachineConfig cfg;
  cfg.spindle.axial_runout_m = 0.2e-6;
  const simulators::machine::Machine m(cfg);
  simulators::machine::FacingSpec spec;
  spec.x_end_m = 0.01;
  spec.profile_step_m = 1e-4;
  spec.spindle_rpm = 107;
  spec.tool_nose_radius_m = 0;
  const auto plain = m.facing_profile(spec);
  spec.runout_along_path = true;
  const auto path = m.facing_profile(spec);
  ASSERT_EQ(plain.size(), path.size());
  double max_dev = 0;
  for (std::size_t i = 0; i < plain.size(); ++i) {
    const double theta = 2 * std::numbers::pi * 107.0 / 60.0 * path[i].t_s;
    EXPECT_NEAR(path[i].z_m - plain[i].z_m, 0.2e-6 * std::cos(2 * theta), 1e-12);
    max_dev = std::max(max_dev, std::abs(plain[i].z_m));
  }
  EXPECT_LT(max_dev, 1e-12);  // a perfect machine faces flat without the option
}

// A real recording's start_time_s may be Unix-epoch seconds (~1.8e9): time-dependent terms (drift,
// vibration, spindle run-out phase) must come out as on a clock that starts at 0, to the 1e-16 relative
// (0.2 us) such a clock keeps of each time stamp: 1e-6 relative, or 1 % of the uncertainty.
TEST(ExplainScenarios, FindingsDoNotDependOnWhereTheMachineClockStarts) {
  for (const char* name :
       {"dbb_thermal_bar", "dbb_cyclic", "dbb_vibration", "flatness_spindle_runout", "flatness_thermal_two_feeds"}) {
    simulators::scenarios::ScenarioOptions epoch;
    epoch.clock_origin_s = 1.8e9;
    const auto a = simulators::scenarios::run_scenario(name);
    const auto b = simulators::scenarios::run_scenario(name, epoch);
    EXPECT_TRUE(b.pass) << name << ": " << b.failure;
    ASSERT_EQ(a.report.findings.size(), b.report.findings.size()) << name;
    for (std::size_t k = 0; k < a.report.findings.size(); ++k) {
      const auto& fa = a.report.findings[k];
      const auto& fb = b.report.findings[k];
      EXPECT_EQ(fa.effect, fb.effect) << name;
      EXPECT_NEAR(fa.heldout_rms_um_after, fb.heldout_rms_um_after, 1e-6 * std::abs(fa.heldout_rms_um_after)) << name;
      ASSERT_EQ(fa.parameters.size(), fb.parameters.size()) << name;
      for (std::size_t j = 0; j < fa.parameters.size(); ++j)
        EXPECT_NEAR(fa.parameters[j].value, fb.parameters[j].value,
                    std::max(1e-6 * std::abs(fa.parameters[j].value), 0.01 * fa.parameters[j].u))
            << name << " " << fa.effect << " " << fa.parameters[j].name;
    }
    EXPECT_NEAR(a.report.final_fit.heldout_rms_um, b.report.final_fit.heldout_rms_um,
                1e-6 * a.report.final_fit.heldout_rms_um)
        << name;
  }
}

// Runs without start_time_s have a clock each: a vibration keeps its frequency and amplitude from run
// to run but not its phase, so each run gets its own; the two phases differ by 2 pi f times the runs'
// true offset (60.05 s apart here, not a whole number of periods).
TEST(ExplainScenarios, AVibrationIsFoundInRunsWithoutACommonClock) {
  constexpr double f_hz = 7.3, apart_s = 60.05;
  simulators::machine::MachineConfig cfg;
  cfg.axis[0].vibration_amplitude_m = 0.5e-6;
  cfg.axis[0].vibration_frequency_hz = f_hz;
  const simulators::machine::Machine m(cfg);
  std::vector<guideway::formats::DbbRun> runs;
  for (int k = 0; k < 2; ++k) {
    simulators::machine::DbbCircleSpec spec;
    spec.direction = k == 0 ? guideway::formats::DbbDirection::ccw : guideway::formats::DbbDirection::cw;
    spec.t0_s = k * apart_s;
    spec.sample_rate_hz = 30.0;  // 3 samples per degree: Nyquist 15 Hz
    spec.seed = 7 + static_cast<std::uint64_t>(k);
    runs.push_back(guideway::simulators::machine::simulate_dbb_run(m, spec, "run" + std::to_string(k + 1)));
    runs.back().metadata.erase("start_time_s");  // recorded on clocks of their own
  }
  const models::explain::Report r = models::explain::explain_dbb_report(runs);
  ASSERT_FALSE(r.findings.empty()) << models::explain::to_text(r);
  EXPECT_EQ(r.findings.front().effect, "vibration");
  std::map<std::string, double> v;
  for (const auto& p : r.findings.front().parameters) v[p.name] = p.value;
  ASSERT_TRUE(v.contains("vibration_x_um") && v.contains("vibration_phase_x_deg_run1") &&
              v.contains("vibration_phase_x_deg_run2"))
      << models::explain::to_text(r);
  EXPECT_NEAR(v["vibration_x_um"], 0.5, 0.01);
  EXPECT_NEAR(v["vibration_hz"], f_hz, 0.002);
  const double turn =
      std::remainder(v["vibration_phase_x_deg_run2"] - v["vibration_phase_x_deg_run1"] - 360 * f_hz * apart_s, 360.0);
  EXPECT_NEAR(turn, 0.0, 5.0) << "phase difference against 2 pi f dt";
  EXPECT_LT(r.final_fit.heldout_rms_um, 0.5 * r.baseline.heldout_rms_um);
}

// Four runs without a common clock: whole runs would be held out, but a phase per run cannot predict a
// run it never saw, so the held-out rows are blocks of every run and the vibration is still found.
TEST(ExplainScenarios, PerRunTermsKeepHeldOutRowsInEveryRun) {
  simulators::machine::MachineConfig cfg;
  cfg.axis[0].vibration_amplitude_m = 0.5e-6;
  cfg.axis[0].vibration_frequency_hz = 7.3;
  cfg.dbb.noise_m = 0.4e-6;
  const simulators::machine::Machine m(cfg);
  std::vector<guideway::formats::DbbRun> runs;
  for (int k = 0; k < 4; ++k) {
    simulators::machine::DbbCircleSpec spec;
    spec.direction = k % 2 == 0 ? guideway::formats::DbbDirection::ccw : guideway::formats::DbbDirection::cw;
    spec.t0_s = k * 60.05;
    spec.sample_rate_hz = 30.0;
    spec.seed = 11 + static_cast<std::uint64_t>(k);
    runs.push_back(guideway::simulators::machine::simulate_dbb_run(m, spec, "run" + std::to_string(k + 1)));
    runs.back().metadata.erase("start_time_s");  // recorded on clocks of their own
  }
  const models::explain::Report r = models::explain::explain_dbb_report(runs);
  EXPECT_EQ(r.heldout_scheme.find("leave-one-run-out"), std::string::npos) << r.heldout_scheme;
  ASSERT_FALSE(r.findings.empty()) << models::explain::to_text(r);
  EXPECT_EQ(r.findings.front().effect, "vibration");
  EXPECT_LT(r.final_fit.heldout_rms_um, r.baseline.heldout_rms_um);
}

// The vibration's reported uncertainties describe its scatter over noise draws (frequency and phase
// searched, amplitude fitted): sd over 10 seeds within a factor 2 of the mean reported u.
TEST(ExplainScenarios, VibrationUncertaintiesMatchTheScatterOverSeeds) {
#if defined(GUIDEWAY_SANITIZED_ADDRESS)
  // Statistics over ten seeds of one scenario that MeetsItsExpectation runs once (9.7 s under ASan).
  GTEST_SKIP() << "a statistical test over seeds: run in the Release build, not under ASan";
#endif
  std::map<std::string, std::vector<double>> values, us;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    simulators::scenarios::ScenarioOptions o;
    o.seed = seed;
    const auto r = simulators::scenarios::run_scenario("dbb_vibration", o);
    ASSERT_FALSE(r.report.findings.empty()) << seed;
    for (const auto& p : r.report.findings.front().parameters) {
      values[p.name].push_back(p.value);
      us[p.name].push_back(p.u);
    }
  }
  for (const char* name : {"vibration_hz", "vibration_phase_x_deg", "vibration_x_um"}) {
    const auto& v = values[name];
    ASSERT_EQ(v.size(), 10u) << name;
    double mean = 0, var = 0, u = 0;
    for (double x : v) mean += x / 10;
    for (double x : v) var += (x - mean) * (x - mean) / 9;
    for (double x : us[name]) u += x / 10;
    EXPECT_GT(std::sqrt(var), 0.5 * u) << name;
    EXPECT_LT(std::sqrt(var), 2.0 * u) << name;
  }
}

// Issue #29: a cause outside the library beside a real effect. The knock in the second run is set aside
// and located in every domain (run, time from its start and on the machine clock, angle, once); the
// backlash is found in the rest. Without setting aside (max_set_aside = 0) the slip beside backlash hides it.
TEST(ExplainScenarios, AFaultBesideAnEffectIsSetAsideAndLocatedInEveryDomain) {
  const auto knock = simulators::scenarios::run_scenario("dbb_knock_once");
  ASSERT_TRUE(knock.pass) << knock.failure;
  const models::explain::Location* at = nullptr;
  for (const auto& m : knock.report.remaining)
    for (const auto& l : m.locations)
      if (l.set_aside && !at) at = &l;
  ASSERT_NE(at, nullptr);
  EXPECT_EQ(at->run, "run2 (cw)");
  EXPECT_NEAR(at->t_from_run_start_s.first, 15.0, 0.3);
  EXPECT_TRUE(at->repeats_in.empty());
  // The machine clock: the scenario's clock starts with the first run's feed-in (450 deg at 9.549 deg/s, then
  // 10 s) and the second run's first sample follows its own 45 deg feed-in.
  EXPECT_NEAR(at->t_machine_s.first - at->t_from_run_start_s.first, 47.124 + 10.0 + 4.712, 0.05);
  EXPECT_GT(knock.report.set_aside, 0u);
  EXPECT_LT(knock.report.set_aside, knock.report.n / 20);
  const std::string text = models::explain::to_text(knock.report);
  EXPECT_NE(text.find("run2 (cw)"), std::string::npos) << text;
  EXPECT_NE(text.find("s from its start (machine clock"), std::string::npos) << text;
  EXPECT_NE(text.find("once"), std::string::npos) << text;

  simulators::scenarios::ScenarioOptions off;
  off.explain.max_set_aside = 0;
  const auto hidden = simulators::scenarios::run_scenario("dbb_slip_beside_backlash", off);
  EXPECT_TRUE(hidden.report.findings.empty());  // with it, the backlash is found (MeetsItsExpectation)
}

// Issue #29: one fault is one place. The first pass, with no effect found yet, shows the backlash's lobes beside
// the slip; they were set aside with it (4 places at seed 4, the backlash then 0.72 +/- 0.06 um). A place the
// findings made without it explain (the last pass's model predicts its samples to within the noise) is given
// back: the slip alone is set aside, where it is, once, and the backlash is fitted to the rest.
TEST(ExplainScenarios, OneFaultBesideAnEffectIsOnePlace) {
  simulators::scenarios::ScenarioOptions o;
  o.seed = 4;
  const auto r = simulators::scenarios::run_scenario("dbb_slip_beside_backlash", o);
  ASSERT_TRUE(r.pass) << r.failure << "\n" << models::explain::to_text(r.report);
  std::vector<models::explain::Location> aside;
  for (const auto& m : r.report.remaining)
    for (const auto& l : m.locations)
      if (l.set_aside) aside.push_back(l);
  ASSERT_EQ(aside.size(), 1u) << models::explain::to_text(r.report);
  EXPECT_EQ(aside[0].run, "run1 (ccw)");
  EXPECT_GT(aside[0].where.second, 90.0);
  EXPECT_LE(aside[0].where.first, 100.0);
  EXPECT_TRUE(aside[0].repeats_in.empty());
  ASSERT_EQ(r.report.findings.size(), 1u);
  for (const auto& p : r.report.findings[0].parameters)
    if (p.name == "backlash_x_um") EXPECT_LT(std::abs(p.value - 0.8), 3 * p.u) << p.value << " +/- " << p.u;
}

// Issue 41 item 10, the first case: a ball that slips once in its cup 14.4 s into the first run and is seated again
// before the second (the step stays for the rest of its run only). The place is set aside, and nothing is found in the
// rest: the reading stands off after the place in its run and, apart, in the runs after it. With one offset over both,
// the second run's level was left to a ccw/cw effect: lateral play X -0.93 / Y +0.94 um on a machine with none.
TEST(ExplainScenarios, ASlipSeatedAgainBeforeTheNextRunIsSetAsideWithNothingFoundBesideIt) {
  std::vector<bool> densities{true};
#if !defined(GUIDEWAY_SANITIZED_ADDRESS)
  densities.push_back(false);  // and the full density (its table row over seeds 1-5: explain_scenarios_full)
#endif
  for (const bool quick : densities) {
    simulators::scenarios::ScenarioOptions o;
    o.quick = quick;
    const auto r = simulators::scenarios::run_scenario("dbb_slip_reseated", o);
    EXPECT_TRUE(r.pass) << "quick " << quick << ": " << r.failure << "\n" << models::explain::to_text(r.report);
    EXPECT_TRUE(r.report.findings.empty()) << models::explain::to_text(r.report);
    EXPECT_GT(r.report.set_aside, 0u);
  }
}

// Issue 41 item 10: the slip seated again before the next run, alone and beside real effects, at quick density over
// seeds 1-5: no false finding at any seed. At seed 2 the first pass explained the slip alone with a thermal drift, a
// servo lag and a lateral play and left nothing structured, so nothing was set aside; a step in the run's level
// (engine/level_step.hpp) is now the rival such findings are judged against. Beside X backlash and a Y vibration the
// backlash's reversal 42.5 deg after the slip is a stronger step beside the base alone: at seed 2 it could not win and
// the false findings stood; at seed 1 the first pass ended unexplained and the place set aside reached the reversal,
// the backlash then 0.55 um beside a thermal drift and a servo lag. The step is now sought beside the findings (or the
// effects held before the share rule dropped one) too (winning_step).
TEST(ExplainScenarios, ASlipSeatedAgainLeavesNoFalseFindingAtAnyQuickSeed) {
  for (const char* name : {"dbb_slip_reseated", "dbb_slip_reseated_beside_lateral", "dbb_slip_reseated_beside_two",
                           "dbb_slip_reseated_beside_backlash_vibration"}) {
    const auto s = simulators::scenarios::summarize_scenario(name, {1, 2, 3, 4, 5});
    ASSERT_EQ(s.runs.size(), s.seeds.size());
    for (std::size_t k = 0; k < s.runs.size(); ++k) {
      const auto& r = s.runs[k];
      EXPECT_TRUE(r.extra.empty()) << name << ", seed " << s.seeds[k] << ": " << models::explain::to_text(r.report);
      EXPECT_TRUE(r.pass) << name << ", seed " << s.seeds[k] << ": " << r.failure;
    }
  }
}

// Issue 41 item 10, the second case: the ball slip beside 0.8 um X backlash at issue 45's density (2 x 18,859
// samples, 52 a degree) reported a lateral play and a vibration beside the backlash, neither of which the machine has.
TEST(ExplainScenarios, ASlipBesideBacklashAtTheBenchDensityFindsTheBacklashAlone) {
#if defined(GUIDEWAY_SANITIZED_ADDRESS)
  // 2 x 18,859 samples: 2 s of CPU in Release, minutes under ASan for code the scenarios above run at 3 a degree.
  GTEST_SKIP() << "the bench's density: run in the Release build, not under ASan";
#endif
  simulators::scenarios::ScenarioOptions o;
  o.samples_per_deg = 18859.0 / 360.0;
  const auto r = simulators::scenarios::run_scenario("dbb_slip_beside_backlash", o);
  EXPECT_TRUE(r.pass) << r.failure << "\n" << models::explain::to_text(r.report);
  EXPECT_TRUE(r.extra.empty()) << models::explain::to_text(r.report);
}

// Issue 41 item 10, the third case, as near as the virtual machine traces it offline: the standard test (ccw, then cw,
// 1000 mm/min, r 100 mm) read as a live session reads it (encoder angles, 250 samples a second, 0.1 um bar noise) on a
// machine with backlash, a servo mismatch and a lead-screw error (config/machine-several-effects.toml without its
// vibration and drift). The three are found with their sizes, and no stick-slip: live, one was reported at 0.12 um,
// 10 Hz and 50 ms, its decay at its grid's edge. A stick-slip is now taken only where a step past such an edge fits
// worse (Variant::beyond).
TEST(ExplainScenarios, TheLiveStandardTestOfThreeEffectsFindsThemAndNoStickSlip) {
#if defined(GUIDEWAY_SANITIZED_ADDRESS)
  GTEST_SKIP() << "2 x 11,800 samples: run in the Release build, not under ASan";
#endif
  auto cfg = simulators::machine::load_machine_config(GUIDEWAY_SOURCE_DIR "/config/machine-several-effects.toml");
  cfg.axis[0].vibration_amplitude_m = 0;
  cfg.axis[0].drift_m_per_s = 0;
  const simulators::machine::Machine m(cfg);
  std::vector<guideway::formats::DbbRun> runs;
  double t0 = 0;
  for (int k = 0; k < 2; ++k) {
    simulators::machine::DbbCircleSpec spec;
    spec.direction = k == 0 ? guideway::formats::DbbDirection::ccw : guideway::formats::DbbDirection::cw;
    spec.sample_rate_hz = 250.0;
    spec.t0_s = t0;
    spec.seed = 41 + static_cast<std::uint64_t>(k);
    runs.push_back(simulators::machine::simulate_dbb_run(m, spec, "run" + std::to_string(k + 1),
                                                         simulators::machine::AngleSource::encoders));
    const double omega = spec.feed_m_per_s / spec.radius_m;
    t0 += (2 * std::numbers::pi + 2 * spec.overshoot_rad) / omega + 1.0;
  }
  const models::explain::Report r = models::explain::explain_dbb_report(runs);
  std::map<std::string, double> found;
  for (const auto& f : r.findings) {
    EXPECT_NE(f.effect, "stick_slip") << models::explain::to_text(r);
    for (const auto& p : f.parameters) found[p.name] = p.value;
  }
  ASSERT_TRUE(found.contains("backlash_x_um") && found.contains("servo_mismatch_ms") &&
              found.contains("cyclic_error_y_um"))
      << models::explain::to_text(r);
  EXPECT_NEAR(found["backlash_x_um"], 1.0, 0.1);
  EXPECT_NEAR(found["backlash_y_um"], 0.6, 0.1);
  EXPECT_NEAR(found["servo_mismatch_ms"], -0.03, 0.006);
  EXPECT_NEAR(found["cyclic_error_y_um"], 0.4, 0.04);
}
