// Partial arcs and gaps (issue 27): a run of 180 deg or more and runs with dropouts are identified, what an
// arc cannot separate is refused by name with the reason, each plane (xy 360 deg, xz and yz 220 deg arcs)
// recovers the virtual machine's squareness, scale mismatch and backlash within u, and the planes' summary
// brings them together. The least-squares circle of a gappy partial arc is checked against numpy.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <numbers>
#include <random>

#include "dbb_test_support.hpp"
#include "formats/dbb_run.hpp"
#include "models/dbb/identify.hpp"
#include "models/dbb/json.hpp"
#include "models/dbb/three_planes.hpp"
#include "models/explain/dbb_explain.hpp"
#include "test_support.hpp"

namespace {

using namespace guideway;
using simulators::machine::Plane;
constexpr double deg = std::numbers::pi / 180.0;

// Errors each plane sees: squareness per plane, a scale and a backlash per axis (all axes with the same
// servo lag, so no servo mismatch), noise 0.1 um.
simulators::machine::MachineConfig three_plane_machine() {
  simulators::machine::MachineConfig m;
  m.name = "three-planes";
  m.noise.seed = 27;
  m.dbb.noise_m = 0.1e-6;
  const double scale_ppm[3] = {-10, 10, 20}, backlash_um[3] = {1.0, 2.0, 3.0};
  for (int k = 0; k < 3; ++k) {
    m.axis[static_cast<std::size_t>(k)].scale = scale_ppm[k] * 1e-6;
    m.axis[static_cast<std::size_t>(k)].backlash_m = backlash_um[k] * 1e-6;
    m.axis[static_cast<std::size_t>(k)].servo_lag_s = 0.03;
  }
  m.squareness = {30e-6, 25e-6, -15e-6};
  return m;
}

// A CCW and a CW run in `plane`: the full circle in xy, else the 220 deg arc on the side away from the
// table (z above the centre: -20 to 200 deg).
std::vector<formats::DbbRun> plane_runs(const simulators::machine::Machine& m, Plane plane, std::uint64_t seed) {
  std::vector<formats::DbbRun> runs;
  for (const bool ccw : {true, false}) {
    simulators::machine::DbbCircleSpec s;
    s.radius_m = 0.1;
    s.plane = plane;
    s.direction = ccw ? formats::DbbDirection::ccw : formats::DbbDirection::cw;
    s.seed = seed + (ccw ? 0 : 1);
    if (plane != Plane::xy) {
      s.data_arc_rad = 220 * deg;
      s.start_angle_rad = (ccw ? -20 : 200) * deg;
    }
    runs.push_back(simulators::machine::simulate_dbb_run(m, s, ccw ? "ccw" : "cw"));
  }
  return runs;
}

const models::dbb::Estimate& get(const std::vector<models::dbb::Estimate>& list, const std::string& name) {
  static const models::dbb::Estimate none{"missing", NAN, NAN, false};
  for (const auto& e : list)
    if (e.name == name) return e;
  ADD_FAILURE() << name << " not reported";
  return none;
}

// Within k standard uncertainties of the truth, with a floor for what the model leaves (the deadband's shape,
// the servo lag's radius change): a partial arc's u grows, the check with it.
void expect_within(const models::dbb::Estimate& e, double truth, double floor, const std::string& what) {
  EXPECT_TRUE(std::isfinite(e.u)) << what;
  EXPECT_LE(std::abs(e.value - truth), 3 * e.u + floor)
      << what << ": " << e.value << " +- " << e.u << ", truth " << truth;
}

TEST(DbbArcsTest, GapsAreFoundDescribedAndKeepTheRun) {
  const simulators::machine::Machine m(three_plane_machine());
  const formats::DbbRun full = plane_runs(m, Plane::xy, 5).front();
  // 1.1 s at 1000 mm/min on r = 100 mm: 10.5 deg.
  const formats::DbbRun gappy = simulators::machine::with_dropout(full, 7.0, 1.1);
  const auto gaps = formats::dbb_run_gaps(gappy);
  ASSERT_EQ(gaps.size(), 1u);
  EXPECT_NEAR(gaps[0].duration_s(), 1.1, 0.011);
  const double omega = (1.0 / 60.0) / 0.1;  // rad/s
  EXPECT_NEAR(gaps[0].angle_rad(), 1.1 * omega, 0.2 * deg);
  EXPECT_NEAR(gaps[0].from_s, 7.0, 0.011);  // the last sample before it
  const std::string text = formats::describe_gap(gaps[0]);
  EXPECT_NE(text.find("gap of 10.6 deg (1.11 s) from 66.8 to 77.4 deg (t 7.00 to 8.11 s, after sample 668)"),
            std::string::npos)
      << text;
  EXPECT_TRUE(formats::dbb_run_gaps(full).empty());
  // Written and read back, the gap is still there and the run still valid.
  test::TempDir dir;
  formats::write_dbb_run(gappy, dir.file("g.csv"));
  EXPECT_EQ(formats::dbb_run_gaps(formats::read_dbb_run(dir.file("g.csv"))).size(), 1u);
}

TEST(DbbArcsTest, RefusesWhatIsLeftTooLittle) {
  const simulators::machine::Machine m(three_plane_machine());
  const formats::DbbRun full = plane_runs(m, Plane::xy, 5).front();
  // A 190 deg dropout leaves 170 deg of the circle.
  try {
    (void)simulators::machine::with_dropout(full, 5.0, 190 * deg * 0.1 / (1.0 / 60.0));
    ADD_FAILURE() << "a run with 170 deg left was accepted";
  } catch (const formats::DbbRunFormatError& e) {
    EXPECT_NE(std::string(e.what()).find("after its gaps the samples cover only 170."), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("at least 180 deg must be left (gap of 190."), std::string::npos) << e.what();
  }
  // An arc under 180 deg.
  simulators::machine::DbbCircleSpec s;
  s.data_arc_rad = 150 * deg;
  try {
    (void)models::dbb::identify({simulators::machine::simulate_dbb_run(m, s, "short")});
    ADD_FAILURE() << "a 150 deg arc was identified";
  } catch (const formats::DbbRunFormatError& e) {
    EXPECT_NE(std::string(e.what()).find("partial arc: the samples cover 150.1 deg, a DBB run needs an arc of at "
                                         "least 180 deg"),
              std::string::npos)
        << e.what();
  }
}

TEST(DbbArcsTest, AnArcWithoutAReversalOfAnAxisRefusesItsReversalTermsByName) {
  // 90 to 270 deg: X reverses at 180 inside it, Y at both ends only.
  const simulators::machine::Machine m(three_plane_machine());
  std::vector<formats::DbbRun> runs;
  for (const bool ccw : {true, false}) {
    simulators::machine::DbbCircleSpec s;
    s.radius_m = 0.1;
    s.direction = ccw ? formats::DbbDirection::ccw : formats::DbbDirection::cw;
    s.data_arc_rad = 180 * deg;
    s.start_angle_rad = (ccw ? 90 : 270) * deg;
    runs.push_back(simulators::machine::simulate_dbb_run(m, s, ccw ? "ccw" : "cw"));
  }
  const auto id = models::dbb::identify(runs);
  const auto& refused = id.diagnostics_fit.unidentifiable;
  for (const char* name : {"backlash_y_um", "lateral_play_y_um", "reversal_spike_y_um"})
    EXPECT_NE(std::find(refused.begin(), refused.end(), name), refused.end()) << name;
  EXPECT_EQ(std::find(refused.begin(), refused.end(), "backlash_x_um"), refused.end());
  ASSERT_FALSE(id.diagnostics_fit.why.empty());
  const auto why = std::find_if(id.diagnostics_fit.why.begin(), id.diagnostics_fit.why.end(),
                                [](const std::string& w) { return w.starts_with("backlash_y_um: "); });
  ASSERT_NE(why, id.diagnostics_fit.why.end());
  EXPECT_NE(why->find("no reversal of Y lies inside the data arcs (90.0 to 270.0 deg, 270.0 to 90.0 deg"),
            std::string::npos)
      << *why;
  // Lai's backlash of the second axis too, and the JSON says why.
  EXPECT_NE(std::find(id.fit.unidentifiable.begin(), id.fit.unidentifiable.end(), "backlash_y_um"),
            id.fit.unidentifiable.end());
  EXPECT_TRUE(models::dbb::to_json(id)["diagnostics_fit"].contains("why"));
  // X's backlash is read from its one reversal.
  expect_within(get(id.diagnostics, "backlash_x_um"), 1.0, 0.1, "backlash x on 90..270");
}

struct PlaneTruth {
  Plane plane;
  std::string name, a, b;
  double squareness_urad, scale_mismatch_ppm, backlash_a_um, backlash_b_um;
};

TEST(DbbArcsTest, EachPlaneRecoversItsTermsAndTheSummaryBringsThemTogether) {
  const simulators::machine::Machine m(three_plane_machine());
  const PlaneTruth truth[] = {{Plane::xy, "xy", "x", "y", 30, -20, 1, 2},
                              {Plane::xz, "xz", "x", "z", 25, -30, 1, 3},
                              {Plane::yz, "yz", "y", "z", -15, -10, 2, 3}};
  std::vector<models::dbb::Identification> ids;
  std::uint64_t seed = 100;
  for (const auto& t : truth) {
    const auto id = models::dbb::identify(plane_runs(m, t.plane, seed += 10));
    ASSERT_EQ(id.plane, t.name);
    expect_within(get(id.diagnostics, "squareness_urad"), t.squareness_urad, 0.5, t.name + " squareness");
    expect_within(get(id.diagnostics, "scale_mismatch_ppm"), t.scale_mismatch_ppm, 0.5, t.name + " scale mismatch");
    expect_within(get(id.diagnostics, "backlash_" + t.a + "_um"), t.backlash_a_um, 0.05, t.name + " backlash " + t.a);
    expect_within(get(id.diagnostics, "backlash_" + t.b + "_um"), t.backlash_b_um, 0.05, t.name + " backlash " + t.b);
    if (t.plane != Plane::xy) {
      EXPECT_NEAR(id.runs.front().data_arc_deg, 220.0, 1e-9);
      EXPECT_TRUE(id.diagnostics_fit.unidentifiable.empty()) << t.name;
    }
    ids.push_back(id);
  }
  const models::dbb::PlanesSummary s = models::dbb::summarize_planes(ids);
  ASSERT_EQ(s.squareness.size(), 3u);
  EXPECT_EQ(s.squareness[1].name, "squareness_xz_urad");
  EXPECT_NEAR(s.squareness[1].value, 25, 3 * s.squareness[1].u + 0.5);
  EXPECT_EQ(s.scale_mismatch[2].name, "scale_mismatch_yz_ppm");
  ASSERT_EQ(s.backlash.size(), 3u);
  const double backlash_um[3] = {1, 2, 3};
  for (std::size_t k = 0; k < 3; ++k) {
    const auto& b = s.backlash[k];
    EXPECT_EQ(b.from.size(), 2u) << b.name;  // every axis is in two of the three planes
    for (const auto& f : b.from)
      EXPECT_LE(std::abs(f.value - backlash_um[k]), 3 * f.u + 0.05) << b.name << " from " << f.plane;
    // Agreement as the summary judges it (k = 2), and a note with the numbers when they do not.
    EXPECT_EQ(b.consistent, models::dbb::figures_agree(b.from[0].value, b.from[0].u, b.from[1].value, b.from[1].u));
    EXPECT_EQ(b.note.empty(), b.consistent) << b.note;
    EXPECT_LE(std::abs(b.value - backlash_um[k]), 3 * b.u + 0.05) << b.name << " " << b.value << " +- " << b.u;
  }
  EXPECT_EQ(s.backlash[2].name, "backlash_z_um");
  // Scale mismatches close around the three planes: (x - y) + (y - z) - (x - z) = 0.
  EXPECT_NEAR(s.scale_mismatch[0].value + s.scale_mismatch[2].value - s.scale_mismatch[1].value, 0.0,
              3 * std::sqrt(std::pow(s.scale_mismatch[0].u, 2) + std::pow(s.scale_mismatch[1].u, 2) +
                            std::pow(s.scale_mismatch[2].u, 2)) +
                  1.0);
  // One ranking across the planes, largest first, percentages of the largest G.
  ASSERT_GE(s.ranking.size(), 6u);
  for (std::size_t k = 1; k < s.ranking.size(); ++k)
    EXPECT_GE(s.ranking[k - 1].contribution_um, s.ranking[k].contribution_um);
  EXPECT_NEAR(s.ranking.front().percent, 100 * s.ranking.front().contribution_um / s.circular_deviation_um, 1e-9);
  const auto j = models::dbb::to_json(s);
  EXPECT_TRUE(j["backlash"]["backlash_z_um"]["consistent"].get<bool>());
  EXPECT_EQ(j["backlash"]["backlash_z_um"]["from"].size(), 2u);
}

TEST(DbbArcsTest, PlanesThatDisagreeAreSaidToWithTheirNumbers) {
  models::dbb::Identification xy, xz;
  xy.plane = "xy";
  xy.diagnostics = {{"backlash_x_um", 1.0, 0.02}, {"squareness_urad", 30, 0.3}};
  xz.plane = "xz";
  xz.diagnostics = {{"backlash_x_um", 1.5, 0.03}};
  const auto s = models::dbb::summarize_planes({xy, xz});
  ASSERT_EQ(s.backlash.size(), 1u);  // x from two planes (y and z: no plane gives them)
  EXPECT_FALSE(s.backlash[0].consistent);
  EXPECT_NE(
      s.backlash[0].note.find("the xy plane gives 1.000 ± 0.020 µm, the xz plane 1.500 ± 0.030 µm; they differ by "
                              "0.5, more than twice their combined uncertainty (0.07)"),
      std::string::npos)
      << s.backlash[0].note;
  EXPECT_TRUE(models::dbb::figures_agree(1.0, 0.02, 1.05, 0.03));
  EXPECT_THROW((void)models::dbb::summarize_planes({xy, xy}), std::invalid_argument);
  EXPECT_THROW((void)models::dbb::summarize_planes({}), std::invalid_argument);
}

TEST(DbbArcsTest, AGappyRunIsIdentifiedWithSlightlyLargerUncertainty) {
  const simulators::machine::Machine m(three_plane_machine());
  const auto runs = plane_runs(m, Plane::xz, 300);
  auto gappy = runs;
  // 1.1 s from 10.5 s: 80 to 91 deg of the CCW arc, over Z's reversal at 90 deg.
  gappy[0] = simulators::machine::with_dropout(runs[0], 10.5, 1.1);
  const auto a = models::dbb::identify(runs);
  const auto b = models::dbb::identify(gappy);
  EXPECT_EQ(b.runs[0].gaps, 1u);
  // The u are s sqrt((J^T W J)^-1): the samples lost make the second factor grow; s, the residual's scatter,
  // moves with the noise the gap took away, so the comparison is per unit of s. Lai's fit has the same terms
  // with and without the gap (the diagnostics search a cyclic error, which noise may or may not show).
  const double s_ratio = b.fit.rms_um / a.fit.rms_um;
  for (const char* name : {"S_x", "S_y", "backlash_y_um", "a2_per_mm"}) {
    const auto& whole = get(a.lai3, name);
    const auto& with_gap = get(b.lai3, name);
    EXPECT_GT(with_gap.u / s_ratio, whole.u) << name;
    EXPECT_LT(with_gap.u, 1.5 * whole.u) << name;
    std::printf("%s: u %.4g without the gap, %.4g with it (residual rms ratio %.4f)\n", name, whole.u, with_gap.u,
                s_ratio);
  }
  expect_within(get(b.diagnostics, "squareness_urad"), 25, 0.5, "squareness with a gap");
  const bool noted = std::any_of(b.notes.begin(), b.notes.end(), [](const std::string& n) {
    return n.find("ccw: gap of 10.6 deg (1.11 s) from 80.") != std::string::npos;
  });
  EXPECT_TRUE(noted);
}

TEST(DbbArcsTest, RandomGapsNeverCrash) {
  const simulators::machine::Machine m(three_plane_machine());
  const auto runs = plane_runs(m, Plane::yz, 400);
  std::mt19937_64 rng(2711);
  std::uniform_real_distribution<double> start(-1.0, 24.0), length(0.0, 4.0);
  int identified = 0, refused = 0;
  for (int trial = 0; trial < 12; ++trial) {
    auto gappy = runs;
    try {
      for (auto& r : gappy)
        for (int g = 0; g < 2; ++g) r = simulators::machine::with_dropout(r, start(rng), length(rng));
      const auto id = models::dbb::identify(gappy);
      ASSERT_EQ(id.runs.size(), 2u);
      for (const auto& e : id.diagnostics) EXPECT_TRUE(std::isfinite(e.value)) << e.name;
      ++identified;
    } catch (const formats::DbbRunFormatError& e) {
      EXPECT_NE(std::string(e.what()), "");
      ++refused;
    }
  }
  EXPECT_GT(identified, 0);
  EXPECT_EQ(identified + refused, 12);
}

TEST(DbbArcsTest, ExplainAcceptsPartialArcsAndSaysWhatTheyHold) {
  const simulators::machine::Machine m(three_plane_machine());
  auto runs = plane_runs(m, Plane::yz, 600);
  runs[1] = simulators::machine::with_dropout(runs[1], 6.0, 1.1);
  const models::explain::Report r = models::explain::explain_dbb_report(runs);
  const auto has = [&](const std::string& text) {
    return std::any_of(r.notes.begin(), r.notes.end(),
                       [&](const std::string& n) { return n.find(text) != std::string::npos; });
  };
  EXPECT_TRUE(has("ccw: a partial data arc of 220.0 deg (-20.0 to 200.0 deg)"));
  EXPECT_TRUE(has("cw: gap of "));
  EXPECT_TRUE(has("Z reverses at 90 and 270 deg: 90 deg inside the data"));
  EXPECT_TRUE(std::isfinite(r.final_fit.rms_um));
  EXPECT_LT(r.final_fit.rms_um, r.baseline.rms_um);
}

bool have_numpy() { return std::system("/usr/bin/python3 -c 'import numpy, scipy' >/dev/null 2>&1") == 0; }

TEST(DbbArcsTest, LeastSquaresCircleOfAGappyPartialArcMatchesNumpy) {
  if (!have_numpy()) GTEST_SKIP() << "/usr/bin/python3 with numpy and scipy is not available";
  const simulators::machine::Machine m(three_plane_machine());
  const auto run = simulators::machine::with_dropout(plane_runs(m, Plane::xz, 500)[1], 4.0, 2.0);
  std::vector<double> y;
  for (double d : run.dL_m) y.push_back(d * 1e6);
  const auto c = models::dbb::least_squares_circle(run.angle_rad, y);
  test::TempDir dir;
  {
    std::ofstream in(dir.file("in.csv"));
    in.precision(17);
    for (std::size_t i = 0; i < y.size(); ++i)
      in << "1," << y[i] << ",1," << std::cos(run.angle_rad[i]) << "," << std::sin(run.angle_rad[i]) << "\n";
  }
  const std::string cmd = "/usr/bin/python3 " GUIDEWAY_SOURCE_DIR "/tests/models/common/dbb_lsq_oracle.py " +
                          dir.file("in.csv") + " " + dir.file("out.txt");
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream out(dir.file("out.txt"));
  std::string key;
  double rank = 0, rms = 0, cond = 0, x[3], u[3];
  out >> key >> rank >> key >> rms >> key >> cond;
  for (int k = 0; k < 3; ++k) out >> x[k] >> u[k];
  EXPECT_NEAR(c.mean_um, x[0], 1e-9);
  EXPECT_NEAR(c.cos_um, x[1], 1e-9);
  EXPECT_NEAR(c.sin_um, x[2], 1e-9);
  double ss = 0;
  for (double d : c.deviation_um) ss += d * d;
  EXPECT_NEAR(std::sqrt(ss / static_cast<double>(c.deviation_um.size())), rms, 1e-9);
}

}  // namespace

// A recording that lost samples often (a loaded machine: 11 gaps in one run of the demo's live session) is said
// in one note for the run, with the count, what was lost in all and the first gap; a few gaps one note each.
TEST(DbbArcsTest, ManyGapsOfARunAreOneNote) {
  const simulators::machine::Machine m(three_plane_machine());
  auto runs = plane_runs(m, Plane::xy, 400);
  for (const double start_s : {2.0, 5.0, 8.0, 11.0, 14.0})
    runs[0] = simulators::machine::with_dropout(runs[0], start_s, 0.2);
  runs[1] = simulators::machine::with_dropout(runs[1], 4.0, 0.2);
  const auto notes = models::dbb::identify(runs).notes;
  const auto count = [&](const std::string& text) {
    return std::count_if(notes.begin(), notes.end(),
                         [&](const std::string& n) { return n.find(text) != std::string::npos; });
  };
  EXPECT_EQ(count("ccw: 5 gaps, "), 1) << "the five gaps of the first run in one note";
  EXPECT_EQ(count("ccw: gap of "), 0);
  EXPECT_EQ(count("cw: gap of "), 1) << "the one gap of the second run as before";
}
