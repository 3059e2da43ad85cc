// EXPLAIN for autocollimator traverses (models/explain/traverse_explain) on the virtual machine's X
// carriage: the traverse file with passes (read and refused), what the example machine file holds found
// and nothing else, what one pass cannot tell, and the machine file's [autocollimator] and wave keys.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <iostream>
#include <map>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/csv_table.hpp"
#include "core/toml_access.hpp"
#include "models/explain/explain.hpp"
#include "models/explain/traverse_explain.hpp"
#include "simulators/machine/machine.hpp"
#include "simulators/scenarios/scenarios.hpp"

namespace {

using namespace guideway;
using models::explain::Report;

constexpr double arcsec = 4.84813681109536e-6;

std::map<std::string, models::explain::ParamValue> parameters(const Report& rep) {
  std::map<std::string, models::explain::ParamValue> out;
  for (const auto& f : rep.findings)
    for (const auto& p : f.parameters) out[p.name] = p;
  return out;
}

std::string effects(const Report& rep) {
  std::string s;
  for (const auto& f : rep.findings) s += f.effect + "; ";
  return s;
}

TEST(TraverseFile, PassesForwardAndBackWithTimes) {
  const std::string text =
      "# step_mm = 10\nx_mm,pitch_arcsec,yaw_arcsec,t_s,pass\n"
      "0,1.5,0.1,0,1\n10,1.25,0.2,2,1\n20,1,0.3,4,1\n"
      "20,1.1,0.3,14,2\n10,1.3,0.2,16,2\n0,1.6,0.1,18,2\n";
  const auto passes = models::explain::parse_traverse_passes(text, "t.csv");
  ASSERT_EQ(passes.size(), 2u);
  EXPECT_EQ(passes[0].direction, 1);
  EXPECT_EQ(passes[1].direction, -1);
  EXPECT_EQ(passes[1].source, "t.csv pass 2");
  EXPECT_DOUBLE_EQ(passes[1].t_s.front(), 14.0);
  EXPECT_NEAR(passes[1].pitch_rad.back(), 1.6 * arcsec, 1e-15);
  EXPECT_DOUBLE_EQ(passes[0].step_m, 0.01);
  // A plain traverse (no pass column) is one pass.
  const auto one = models::explain::parse_traverse_passes("# step_mm = 10\nx_mm,pitch_arcsec\n0,1\n10,2\n", "p.csv");
  ASSERT_EQ(one.size(), 1u);
  EXPECT_TRUE(one[0].t_s.empty());
  EXPECT_TRUE(one[0].yaw_rad.empty());
}

TEST(TraverseFile, RefusesWhatCannotBePlaced) {
  const auto error = [](const std::string& text) {
    try {
      models::explain::parse_traverse_passes(text, "bad.csv");
    } catch (const CsvError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // A turn inside a pass, a skipped station, a pass coming back, time running backwards, a span out of range.
  EXPECT_NE(error("# step_mm = 10\nx_mm,pitch_arcsec\n0,1\n10,1\n0,1\n").find("bad.csv:5: x_mm = 0 is not one step"),
            std::string::npos);
  EXPECT_NE(error("# step_mm = 10\nx_mm,pitch_arcsec\n0,1\n20,1\n").find("bad.csv:4:"), std::string::npos);
  EXPECT_NE(error("# step_mm = 10\nx_mm,pitch_arcsec,pass\n0,1,1\n10,1,1\n10,1,2\n0,1,2\n0,1,1\n10,1,1\n")
                .find("pass 1 again"),
            std::string::npos);
  EXPECT_NE(error("# step_mm = 10\nx_mm,pitch_arcsec,t_s\n0,1,5\n10,1,4\n").find("t_s = 4 does not increase"),
            std::string::npos);
  EXPECT_NE(error("# step_mm = 10\nx_mm,pitch_arcsec\n0,-560\n10,700\n")
                .find("bad.csv:4: pitch_arcsec spans 1260\" (from -560 at bad.csv:3 to 700 at bad.csv:4), more than the "
                      "autocollimator's range +-600\" about the readings' middle"),
            std::string::npos);
  // A tilted set-up within the range about its middle is the set-up, not an error.
  EXPECT_EQ(error("# step_mm = 10\nx_mm,pitch_arcsec\n0,890\n10,900\n"), "no error");
  EXPECT_NE(error("# step_mm = 10\nx_mm,pitch_arcsec\n0,1\n").find("at least 2"), std::string::npos);
}

// The example machine (config/machine-example.toml) read forward and back: its drift (0.1"/min) and its
// reflector's rocking (0.2") are named, with their sizes within a few u, and nothing else.
TEST(ExplainTraverse, FindsWhatTheExampleMachineFileHolds) {
  const simulators::machine::MachineConfig cfg = simulators::machine::default_machine_config();
  ASSERT_NEAR(cfg.autocollimator.pitch_drift_rad_per_s, 0.1 * arcsec / 60.0, 1e-15);
  ASSERT_NEAR(cfg.autocollimator.rocking_rad, 0.2 * arcsec, 1e-15);
  simulators::scenarios::SimulatedTraverse t;
  t.seed = 7;
  const Report rep = models::explain::explain_traverses(
      simulators::scenarios::simulated_traverse(simulators::machine::Machine(cfg), t));
  auto p = parameters(rep);
  ASSERT_EQ(rep.findings.size(), 2u) << effects(rep);
  ASSERT_TRUE(p.count("angle_drift_arcsec_per_min")) << effects(rep);
  ASSERT_TRUE(p.count("reflector_rocking_arcsec")) << effects(rep);
  EXPECT_NEAR(p["angle_drift_arcsec_per_min"].value, 0.1, 4 * p["angle_drift_arcsec_per_min"].u);
  EXPECT_NEAR(p["reflector_rocking_arcsec"].value, 0.2, 4 * p["reflector_rocking_arcsec"].u);
  EXPECT_LT(p["reflector_rocking_arcsec"].u, 0.02);  // 0.05" noise over 120 readings, beside the drift
  EXPECT_FALSE(rep.unexplained);
  EXPECT_LT(rep.final_fit.heldout_rms_um, rep.baseline.heldout_rms_um);
}

// One pass alone: time is a line in x and there is no other direction, so neither drift nor rocking is a
// candidate (the notes say why), and the example machine's pass is explained by its base.
TEST(ExplainTraverse, OnePassCannotTellDriftOrRockingAndSaysSo) {
  simulators::scenarios::SimulatedTraverse t;
  t.passes = 1;
  const auto problem = models::explain::traverse_problem(simulators::scenarios::simulated_traverse(
      simulators::machine::Machine(simulators::machine::default_machine_config()), t));
  for (const auto& c : problem.candidates) {
    EXPECT_NE(c.effect, "angle_drift");
    EXPECT_NE(c.effect, "reflector_rocking");
  }
  std::string notes;
  for (const auto& n : problem.notes) notes += n + "\n";
  EXPECT_NE(notes.find("a drift in time is a slope in x"), std::string::npos) << notes;
  EXPECT_NE(notes.find("flips with the direction of travel is not seen"), std::string::npos) << notes;
  const Report rep = models::explain::explain(problem);
  EXPECT_TRUE(rep.findings.empty()) << effects(rep);
}

// A single pass at the session's former default 50 mm steps (12 readings) is refused with the numbers: the engine's
// structure tests take 32 readings, of one pass or of the passes of one file together (issue 41 item 5).
TEST(ExplainTraverse, ASinglePassTooShortForTheTestsIsRefusedWithTheNumbers) {
  simulators::scenarios::SimulatedTraverse t;
  t.step_m = 0.05;
  t.passes = 1;
  const auto passes =
      simulators::scenarios::simulated_traverse(simulators::machine::Machine(simulators::machine::MachineConfig{}), t);
  try {
    models::explain::traverse_problem(passes);
    FAIL() << "refused";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("the longest pass has 12 readings and no other pass of its file"), std::string::npos) << what;
    EXPECT_NE(what.find("a step of 18.75 mm or less"), std::string::npos) << what;
    EXPECT_NE(what.find("passes of one file, forward and return, 32 readings or more together"), std::string::npos)
        << what;
    EXPECT_NE(what.find("identify straightness"), std::string::npos) << what;
  }
}

// Traverses as ISO 230-1 practice takes them (issue 41 items 5 and 6): 600 mm at 25 mm feet, 24 readings a pass,
// four passes forward and back, 2 s a station, 10 s at each turn, 0.05" of noise. The guideway's pitch is a bow a
// drift of 0.25"/min over the four passes hides from a base order chosen without the drift (the polynomial's
// order 1, and the shared means then judged "not a polynomial": a term per station, which takes a wave as geometry).
simulators::machine::MachineConfig iso_traverse_machine() {
  simulators::machine::MachineConfig m;
  m.axis[0].rotation[1].c = {0.0, -6e-6, 1e-5};  // rad, u in m: 1 urad of bow in the slope over 600 mm
  m.noise.autocollimator_rad = 0.05 * arcsec;
  return m;
}

Report explain_iso_traverse(const simulators::machine::MachineConfig& m, std::uint64_t seed,
                            const std::function<void(std::vector<models::explain::TraversePass>&)>& alter = {}) {
  simulators::scenarios::SimulatedTraverse t;
  t.step_m = 0.025;
  t.passes = 4;
  t.seed = seed;
  auto passes = simulators::scenarios::simulated_traverse(simulators::machine::Machine(m), t);
  EXPECT_EQ(passes.front().x_m.size(), 24u);
  if (alter) alter(passes);
  return models::explain::explain_traverses(passes);
}

std::string base_note(const Report& rep) {
  for (const auto& n : rep.notes)
    if (n.rfind("base: ", 0) == 0) return n;
  return "";
}

// The one finding `parameter`, within 4 u of `truth`, and nothing else: the residual left is noise.
void expect_only(const Report& rep, const std::string& parameter, double truth) {
  auto p = parameters(rep);
  ASSERT_EQ(rep.findings.size(), 1u) << effects(rep) << base_note(rep);
  ASSERT_TRUE(p.count(parameter)) << effects(rep);
  EXPECT_NEAR(p[parameter].value, truth, 4 * p[parameter].u);
  EXPECT_FALSE(rep.unexplained);
}

TEST(ExplainIsoTraverse, ADriftIsFoundAndLeavesNoWave) {
  auto m = iso_traverse_machine();
  m.autocollimator.pitch_drift_rad_per_s = 0.25 * arcsec / 60.0;
  const Report rep = explain_iso_traverse(m, 1);
  expect_only(rep, "angle_drift_arcsec_per_min", 0.25);
  // The bow is the polynomial's, not a term per station (item 6).
  EXPECT_NE(base_note(rep).find("straightness polynomial of order 3"), std::string::npos) << base_note(rep);
}

TEST(ExplainIsoTraverse, ARockingIsFound) {
  auto m = iso_traverse_machine();
  m.autocollimator.rocking_rad = 0.3 * arcsec;
  expect_only(explain_iso_traverse(m, 2), "reflector_rocking_arcsec", 0.3);
}

// A rack's wave of 0.5" every 150 mm (6 readings a cycle), alone or beside the drift: each hides the bow from an
// order chosen without it. The wave's size within 4 u and its period within 5 %; the drift's within 4 u.
void expect_rack_wave_found(double drift_arcsec_per_min, std::uint64_t seed) {
  auto m = iso_traverse_machine();
  m.autocollimator.pitch_drift_rad_per_s = drift_arcsec_per_min * arcsec / 60.0;
  m.axis[0].pitch_wave_rad = 0.5 * arcsec;
  m.axis[0].pitch_wave_period_m = 0.15;
  m.axis[0].pitch_wave_phase_rad = 0.7;
  const Report rep = explain_iso_traverse(m, seed);
  auto p = parameters(rep);
  ASSERT_EQ(rep.findings.size(), drift_arcsec_per_min > 0 ? 2u : 1u) << effects(rep) << base_note(rep);
  ASSERT_TRUE(p.count("pitch_wave_arcsec")) << effects(rep);
  EXPECT_NEAR(p["pitch_wave_arcsec"].value, 0.5, 4 * p["pitch_wave_arcsec"].u);
  EXPECT_NEAR(p["pitch_wave_period_mm"].value, 150.0, 7.5);
  if (drift_arcsec_per_min > 0) {
    ASSERT_TRUE(p.count("angle_drift_arcsec_per_min")) << effects(rep);
    EXPECT_NEAR(p["angle_drift_arcsec_per_min"].value, drift_arcsec_per_min, 4 * p["angle_drift_arcsec_per_min"].u);
  }
  EXPECT_FALSE(rep.unexplained);
}

TEST(ExplainIsoTraverse, APitchWaveIsFound) { expect_rack_wave_found(0.0, 3); }

TEST(ExplainIsoTraverse, APitchWaveIsFoundBesideADrift) { expect_rack_wave_found(0.25, 5); }

// Issue 41 item 10, "inside the grid": the pitch wave's band ends at 2.5 stations a cycle (62.5 mm at these 25 mm feet;
// its last line 63.16 mm, 15.83 cycles a metre over the 600 mm span), short of the stations' Nyquist (50 mm). A wave of
// 0.5" every 61.5 mm, past that end, was reported at 63.16 mm as if found; the line a grid step past (61.54 mm) fits
// better, so it is not: `considered` says the optimum lies outside the grid.
TEST(ExplainIsoTraverse, APitchWavePastItsBandIsNotReportedAtTheBandsEnd) {
  auto m = iso_traverse_machine();
  m.axis[0].pitch_wave_rad = 0.5 * arcsec;
  m.axis[0].pitch_wave_period_m = 0.0615;
  m.axis[0].pitch_wave_phase_rad = 0.7;
  const Report rep = explain_iso_traverse(m, 3);
  const double span_m = 0.6, edge_mm = 1e3 / (1.5 / span_m + 32 * 0.25 / span_m);
  for (const auto& f : rep.findings)
    for (const auto& q : f.parameters)
      if (q.name == "pitch_wave_period_mm") EXPECT_GT(std::abs(q.value - edge_mm), 1e-6 * edge_mm) << effects(rep);
  bool wave = false;
  for (const auto& f : rep.findings) wave = wave || f.effect == "pitch_wave";
  if (!wave) {
    std::string verdict;
    for (const auto& c : rep.considered)
      if (c.effect == "pitch_wave") verdict = c.verdict;
    EXPECT_NE(verdict.find("pitch_wave_period_mm = 63.16 is at its grid's edge and 61.54, past it"), std::string::npos)
        << verdict << "\n"
        << models::explain::to_text(rep);
  }
}

// A chip caught under the reflector's rear foot 10 stations into the third pass tilts every later reading of that
// pass by h / L (0.02 um over 25 mm: 0.8 urad, 0.17"): nothing of the library is that, so nothing is found and the
// readings are unexplained -- never a drift or a rocking made of it.
TEST(ExplainIsoTraverse, AChipUnderAFootIsUnexplainedNotAFinding) {
  const double tilt_rad = 0.02e-6 / 0.025;
  const Report rep = explain_iso_traverse(iso_traverse_machine(), 4, [&](auto& passes) {
    for (std::size_t i = 10; i < passes[2].pitch_rad.size(); ++i) passes[2].pitch_rad[i] += tilt_rad;
  });
  EXPECT_TRUE(rep.findings.empty()) << effects(rep);
  EXPECT_TRUE(rep.unexplained);
}

// Issue #29: setting a place aside must leave every pass long enough for the structure tests (32 readings).
// At the session's default 33 stations a pass, a bump of the reflector in the return pass stays where it is,
// unexplained and located, with nothing set aside and a note saying why; it used to be set aside, leaving the
// pass blind to the tests (and, with places in both passes, `explain: every run is shorter than 32 samples`).
TEST(ExplainTraverse, SettingAsideNeverLeavesAPassTooShortForTheTests) {
  simulators::scenarios::SimulatedTraverse t;
  t.step_m = 0.01875;
  t.end_m = 0.6 + t.step_m;  // 33 stations, as the session's
  t.seed = 3;
  auto passes = simulators::scenarios::simulated_traverse(
      simulators::machine::Machine(simulators::machine::default_machine_config()), t);
  ASSERT_EQ(passes.back().x_m.size(), 33u);
  auto& last = passes.back().pitch_rad;
  for (std::size_t i = 12; i < 16; ++i) last[i] += 2.0 * arcsec;  // the reflector knocked for 4 readings
  const Report rep = models::explain::explain_traverses(passes);
  EXPECT_TRUE(rep.unexplained);
  EXPECT_EQ(rep.set_aside, 0u);
  std::string notes;
  for (const auto& n : rep.notes) notes += n + "\n";
  EXPECT_NE(notes.find("not set aside: pass2 (-) would keep fewer than 32 samples"), std::string::npos) << notes;
  ASSERT_FALSE(rep.remaining.empty());
  ASSERT_FALSE(rep.remaining.front().locations.empty()) << rep.remaining.front().where;
  EXPECT_EQ(rep.remaining.front().locations.front().run, "pass2 (-)");
}

// Issue #29: the example machine's drift (0.1"/min) beside its rocking (0.2") at the session's 33 readings a pass,
// forward and back, 3 s a station: the drift's expected t is 7.7 (u 0.013"/min), so it is found at (nearly)
// every noise seed. The share rule used to drop it where the residual left with it was noise (nothing there for
// it to be a partial fit of): the drift "removed only 69-80 % of the structure left without it".
TEST(ExplainTraverse, ADriftWellAboveItsUncertaintyIsFoundAtEverySeed) {
  simulators::scenarios::SimulatedTraverse t;
  t.step_m = 0.01875;
  t.end_m = 0.6 + t.step_m;
  t.dwell_s = 3.0;
  t.turn_s = 3.0;
  const simulators::machine::Machine machine(simulators::machine::default_machine_config());
  int found = 0;
  constexpr int seeds = 20;
  for (int seed = 1; seed <= seeds; ++seed) {
    t.seed = static_cast<std::uint64_t>(seed);
    const Report rep = models::explain::explain_traverses(simulators::scenarios::simulated_traverse(machine, t));
    auto p = parameters(rep);
    if (!p.count("angle_drift_arcsec_per_min")) {
      for (const auto& c : rep.considered)
        if (c.effect == "angle_drift") std::cerr << "seed " << seed << ": angle_drift " << c.verdict << "\n";
      continue;
    }
    ++found;
    EXPECT_LT(std::abs(p["angle_drift_arcsec_per_min"].value - 0.1), 4 * p["angle_drift_arcsec_per_min"].u) << seed;
  }
  std::cerr << "angle_drift found at " << found << " of " << seeds << " seeds\n";
  EXPECT_GE(found, seeds - 1);
}

// A long scan of a rough surface as two passes: 1,200 stations at 0.5 mm, the slope a random walk of 0.05 urad a
// station (no polynomial follows it), a rocking of 0.2", 0.02" of noise, 2 s a station; with `wave_arcsec`, a pitch
// wave every 75 mm (8 cycles over the scan) that both passes read.
std::vector<models::explain::TraversePass> rough_surface_passes(double wave_arcsec = 0.0) {
  constexpr std::size_t stations = 1200;
  std::mt19937_64 rng(41);
  const auto gauss = [&rng] {
    const double u1 = (static_cast<double>(rng() >> 11) + 0.5) * 0x1p-53;
    const double u2 = static_cast<double>(rng() >> 11) * 0x1p-53;
    return std::sqrt(-2 * std::log(u1)) * std::cos(2 * std::numbers::pi * u2);
  };
  std::vector<double> slope(stations);
  double walk = 0;
  for (double& v : slope) v = walk += 0.05e-6 * gauss();
  std::vector<models::explain::TraversePass> passes(2);
  for (int k = 0; k < 2; ++k) {
    auto& p = passes[static_cast<std::size_t>(k)];
    p.source = "rough pass " + std::to_string(k + 1);
    p.direction = k == 0 ? 1 : -1;
    p.step_m = 0.0005;
    for (std::size_t j = 0; j < stations; ++j) {
      const std::size_t s = k == 0 ? j : stations - 1 - j;
      const double x = 0.0005 * static_cast<double>(s);
      p.x_m.push_back(x);
      p.t_s.push_back(2.0 * static_cast<double>(j + k * stations) + 10.0 * k);
      p.pitch_rad.push_back(slope[s] + p.direction * 0.2 * arcsec + 0.02 * arcsec * gauss() +
                            wave_arcsec * arcsec * std::sin(2 * std::numbers::pi * (x + 0.00025) / 0.075 + 0.7));
    }
  }
  return passes;
}

// Issue 41 items 3 and 7: the geometry is the passes' shared part, a term per station fitted out of the readings
// whatever the number of stations (as columns it was given to 512 at most: the polynomial was kept, and what it left
// of the surface was structure the rocking "left without it"); the held-out folds hold whole stations. The surface
// alone has no line standing above its own spectrum: no pitch wave, and `considered` says what its strongest stood at.
TEST(ExplainTraverse, ALongScanOfARoughSurfaceTakesATermPerStation) {
  const Report rep = models::explain::explain_traverses(rough_surface_passes());
  std::string notes;
  for (const auto& n : rep.notes) notes += n + "\n";
  EXPECT_NE(notes.find("base: a term per station (1200 stations"), std::string::npos) << notes;
  EXPECT_NE(rep.heldout_scheme.find("all its readings"), std::string::npos) << rep.heldout_scheme;
  auto p = parameters(rep);
  ASSERT_EQ(rep.findings.size(), 1u) << effects(rep) << notes;
  ASSERT_TRUE(p.count("reflector_rocking_arcsec")) << effects(rep);
  EXPECT_NEAR(p["reflector_rocking_arcsec"].value, 0.2, 4 * p["reflector_rocking_arcsec"].u);
  EXPECT_LT(p["reflector_rocking_arcsec"].u, 0.005);
  EXPECT_FALSE(rep.unexplained) << notes;
  std::string verdict;
  for (const auto& c : rep.considered)
    if (c.effect == "pitch_wave") verdict = c.verdict;
  EXPECT_NE(verdict.find("the geometry's strongest line, at "), std::string::npos) << verdict;
}

// A pitch wave both passes read is geometry the term per station holds, which the engine's tests (of what the passes
// disagree on) cannot judge: it used to be `cannot be fitted`. Judged against the geometry's own spectrum, a wave of
// 0.2" every 75 mm on the rough surface (its random walk's spectrum there: a line would need 0.06" to reach the
// test's 14.5) is found beside the rocking, with its size, phase and period (shared_wave.hpp).
TEST(ExplainTraverse, AWaveBothPassesReadIsFoundAgainstTheGeometrysSpectrum) {
  models::explain::ExplainOptions keep;
  keep.keep_columns = true;
  const Report rep = models::explain::explain_traverses(rough_surface_passes(0.2), keep);
  std::string notes;
  for (const auto& n : rep.notes) notes += n + "\n";
  EXPECT_NE(notes.find("base: a term per station (1200 stations"), std::string::npos) << notes;
  auto p = parameters(rep);
  ASSERT_EQ(rep.findings.size(), 2u) << effects(rep) << notes;
  ASSERT_TRUE(p.count("pitch_wave_arcsec")) << effects(rep) << notes;
  EXPECT_NEAR(p["pitch_wave_arcsec"].value, 0.2, 4 * p["pitch_wave_arcsec"].u);
  EXPECT_LT(p["pitch_wave_arcsec"].u, 0.04);  // the spectrum's, not the passes' scatter (0.02" / sqrt(1200))
  EXPECT_GT(p["pitch_wave_arcsec"].u, 0.001);
  // Counted from x = 0, the scan's end: its u leaves out the period's, which moves it there.
  EXPECT_NEAR(p["pitch_wave_phase_deg"].value, 0.7 * 180 / std::numbers::pi, 15.0);
  EXPECT_NEAR(p["pitch_wave_period_mm"].value, 75.0, 1.5);
  EXPECT_NEAR(p["reflector_rocking_arcsec"].value, 0.2, 4 * p["reflector_rocking_arcsec"].u);
  EXPECT_NE(notes.find("pitch_wave: the geometry the passes share"), std::string::npos) << notes;
  for (const auto& c : rep.considered) EXPECT_NE(c.effect, "pitch_wave") << c.verdict;
  EXPECT_EQ(rep.curve_steps.size(), rep.findings.size() + 1);
  ASSERT_EQ(rep.findings.back().columns_um.size(), 2u);  // its term, for a model that fits it beside its own
  EXPECT_EQ(rep.findings.back().columns_um[0].size(), 2400u);
}

TEST(MachineTraverse, AutocollimatorKeysActOnTheReadingsAsAFileHoldsThem) {
  auto cfg = simulators::machine::parse_machine_config(
      "[autocollimator]\npitch_drift_arcsec_per_min = 0.6\nrocking_arcsec = 0.25\n"
      "[axis.x]\npitch_wave_urad = 2\npitch_wave_period_mm = 50\n",
      "t.toml");
  simulators::machine::TraverseSpec fwd;
  fwd.start_m = 0.0;
  fwd.end_m = 0.1;
  fwd.step_m = 0.0125;  // a quarter of the wave
  fwd.dwell_s = 10.0;
  const auto f = simulators::machine::Machine(cfg).autocollimator_traverse(fwd);
  // pitch read = -rotation: drift 0.1" a station, rocking +0.25" moving +, the wave -2 urad sin(2 pi x / 50 mm).
  for (std::size_t k = 0; k < f.size(); ++k) {
    const double wave = -2e-6 * std::sin(2 * std::numbers::pi * f[k].position_m / 0.05);
    EXPECT_NEAR(-f[k].pitch_rad, 0.1 * arcsec * static_cast<double>(k) + 0.25 * arcsec + wave, 1e-12) << k;
  }
  simulators::machine::TraverseSpec back = fwd;
  std::swap(back.start_m, back.end_m);
  const auto b = simulators::machine::Machine(cfg).autocollimator_traverse(back);
  EXPECT_NEAR(-b[0].pitch_rad, -0.25 * arcsec, 1e-12);  // moving -, at t = 0, x = 0.1 (a whole wave: sin = 0)
  EXPECT_THROW(simulators::machine::parse_machine_config("[autocollimator]\nhead_roll_deg = 60\n", "t.toml"),
               ConfigError);
  EXPECT_THROW(simulators::machine::parse_machine_config("[autocollimator]\nzero = 1\n", "t.toml"), ConfigError);
}

}  // namespace
