// Gaps near a reversal cost the ballbar diagnostics precision, never bias (the demo's live session under load:
// a CW run that lost 53 deg, most of it between 160 and 200 deg around X's reversal, read backlash X 0.634 ±
// 0.039 um for 1). The example machine's standard test (CCW + CW, r = 100 mm, h = 0, angles from the axis
// encoders as a live session's) with gaps like the live ones: every diagnostics term within 3 u of the machine
// file, its backlash within 3 u of Lai's on the same runs, and its u no smaller than without the gaps.
// DbbGapsTest.SeedsStatistics (label slow) repeats it over seeds and counts the terms further than 3 u.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <numbers>
#include <random>
#include <string>

#include "dbb_test_support.hpp"
#include "formats/dbb_run.hpp"
#include "models/dbb/identify.hpp"

namespace {

using namespace guideway;
constexpr double deg = std::numbers::pi / 180.0;

// config/machine-example.toml in the diagnostics' terms at r = 100 mm, h = 0 (docs/conventions.md). Both axes
// lag 30 ms, which shrinks the circle by r (omega tau)^2 / 2 = 12.5 ppm at 1000 mm/min: in both absolute scales.
const std::map<std::string, double>& example_machine_truth() {
  static const std::map<std::string, double> truth{
      {"run1.center_offset_x_um", 2.0},
      {"run1.center_offset_y_um", -3.0},
      {"run2.center_offset_x_um", 2.0},
      {"run2.center_offset_y_um", -3.0},
      {"scale_x_ppm", -10.0 - 12.5},
      {"scale_y_ppm", 10.0 - 12.5},
      {"scale_mismatch_ppm", -20.0},
      {"squareness_urad", 30.0},
      {"backlash_x_um", 1.0},
      {"backlash_y_um", 2.0},
      {"lateral_play_x_um", 0.0},
      {"lateral_play_y_um", 0.0},
      {"servo_mismatch_ms", 0.0},
      {"straightness_x_um", 2.25e-4 * 100 * 100},  // e_y_um of X: 2.25e-4 um/mm^2
      {"straightness_y_um", 2.5e-4 * 100 * 100},   // e_x_um of Y
      // (a3 - b3) r^3: X's cubic -5e-6 um/mm^3 less Y's 5e-6
      {"straightness_cubic_x_minus_y_um", (-5e-6 - 5e-6) * 100 * 100 * 100},
      {"reversal_spike_x_um", 0.0},
      {"reversal_spike_y_um", 0.0},
  };
  return truth;
}

std::vector<formats::DbbRun> standard_test(std::uint64_t seed) {
  const simulators::machine::Machine m(
      simulators::machine::load_machine_config(GUIDEWAY_SOURCE_DIR "/config/machine-example.toml"));
  std::vector<formats::DbbRun> runs;
  for (const bool ccw : {true, false}) {
    simulators::machine::DbbCircleSpec s;
    s.direction = ccw ? formats::DbbDirection::ccw : formats::DbbDirection::cw;
    s.seed = seed + (ccw ? 0 : 1);
    runs.push_back(
        simulators::machine::simulate_dbb_run(m, s, ccw ? "ccw" : "cw", simulators::machine::AngleSource::encoders));
  }
  return runs;
}

// The run less the samples from `from` to `from + length` degrees travelled (a dropout, by time).
formats::DbbRun without_arc(const formats::DbbRun& run, double from_deg, double length_deg) {
  const double omega_deg = run.feed_m_per_s / run.radius_m / deg;
  return simulators::machine::with_dropout(run, run.t_s.front() + from_deg / omega_deg, length_deg / omega_deg);
}

// Gaps like the live session's: in the CW run 30 dropouts of 0.2 to 2 deg between 160 and 200 deg travelled
// (about X's reversal at -180 deg) and 10 anywhere, in the CCW run 8 anywhere.
std::vector<formats::DbbRun> with_live_like_gaps(std::vector<formats::DbbRun> runs, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> cluster(160.0, 200.0), anywhere(5.0, 350.0), length(0.2, 2.0);
  for (int g = 0; g < 30; ++g) runs[1] = without_arc(runs[1], cluster(rng), length(rng));
  for (int g = 0; g < 10; ++g) runs[1] = without_arc(runs[1], anywhere(rng), length(rng));
  for (int g = 0; g < 8; ++g) runs[0] = without_arc(runs[0], anywhere(rng), length(rng));
  return runs;
}

const models::dbb::Estimate* find(const std::vector<models::dbb::Estimate>& list, const std::string& name) {
  for (const auto& e : list)
    if (e.name == name) return &e;
  return nullptr;
}

// The terms of the machine file further than 3 u from it (each said with its value), and the largest |error| / u.
struct Check {
  int off = 0;
  double worst_z = 0;
  std::map<std::string, double> z;  // (value - truth) / u per term
};
Check check_against_truth(const models::dbb::Identification& id, bool print) {
  Check c;
  for (const auto& [name, truth] : example_machine_truth()) {
    const auto* e = find(id.diagnostics, name);
    EXPECT_TRUE(e && e->fitted && std::isfinite(e->u) && e->u > 0) << name << " not fitted";
    if (!e || !(e->u > 0)) continue;
    c.z[name] = (e->value - truth) / e->u;
    const double z = std::abs(c.z[name]);
    c.worst_z = std::max(c.worst_z, z);
    if (z > 3) ++c.off;
    if (print || z > 3)
      std::printf("  %-32s %9.4f ± %.4f  truth %8.3f  (%.1f u)\n", name.c_str(), e->value, e->u, truth, z);
  }
  return c;
}

TEST(DbbGapsTest, GapsAroundAReversalCostPrecisionNotBias) {
  const auto whole = standard_test(7);
  const auto gappy = with_live_like_gaps(whole, 2026);
  const auto a = models::dbb::identify(whole);
  const auto b = models::dbb::identify(gappy);
  EXPECT_GT(b.runs[1].gaps, 15u);
  std::printf("without gaps:\n");
  const Check ca = check_against_truth(a, true);
  std::printf("with %zu + %zu gaps (%zu and %zu samples lost):\n", b.runs[0].gaps, b.runs[1].gaps,
              whole[0].angle_rad.size() - gappy[0].angle_rad.size(),
              whole[1].angle_rad.size() - gappy[1].angle_rad.size());
  const Check cb = check_against_truth(b, true);
  // Over 20 seeds 2 of 360 terms lie beyond 3 u (SeedsStatistics): one seed's gappy fit is held to 3 u, the
  // gapless one it is compared with (scale mismatch 3.1 u here) to 4 u.
  EXPECT_EQ(cb.off, 0) << "terms further than 3 u from the machine file with gaps";
  EXPECT_LT(ca.worst_z, 4.0) << "without gaps";
  // The same backlash as Lai's model reads on the same runs, and a gap costs precision only.
  for (const char* axis : {"x", "y"}) {
    const std::string name = std::string("backlash_") + axis + "_um";
    const auto* d = find(b.diagnostics, name);
    const auto* l = find(b.lai3, name);
    ASSERT_TRUE(d && l) << name;
    EXPECT_LE(std::abs(d->value - l->value), 3 * std::hypot(d->u, l->u))
        << name << ": diagnostics " << d->value << ", Lai " << l->value;
    const auto* w = find(a.diagnostics, name);
    ASSERT_TRUE(w);
    EXPECT_GT(d->u, 0.9 * w->u) << name << ": u with gaps " << d->u << ", without " << w->u;
  }
  // What the cubic term takes out is no longer left in the residual (0.88 um rms before it was fitted).
  EXPECT_LT(b.diagnostics_fit.rms_um, 0.2);
}

// Gaps over the first degrees after each of X's reversals in both runs leave its reversal spike's column
// without a sample: refused by name with that reason, and the rest still read within 3 u.
TEST(DbbGapsTest, ASpikeWithoutSamplesAfterItsReversalIsRefusedByNameWithTheReason) {
  auto runs = standard_test(11);
  // X reverses at 0 and 180 deg: the first 3.3 deg after each go, in the direction of travel (both runs start
  // at X's reversal at 0 deg).
  for (auto& r : runs) r = without_arc(without_arc(r, 179.9, 3.4), -1.0, 4.3);
  const auto id = models::dbb::identify(runs);
  EXPECT_EQ(find(id.diagnostics, "reversal_spike_x_um"), nullptr);
  const auto& why = id.diagnostics_fit.why;
  EXPECT_TRUE(std::any_of(why.begin(), why.end(), [](const std::string& w) {
    return w.starts_with("reversal_spike_x_um: no run holds a sample in the first moments after a reversal of X");
  })) << (why.empty() ? std::string("no reason given") : why.front());
  for (const auto& [name, truth] : example_machine_truth()) {
    if (name == "reversal_spike_x_um") continue;
    const auto* e = find(id.diagnostics, name);
    ASSERT_TRUE(e && e->u > 0) << name;
    EXPECT_LE(std::abs(e->value - truth), 3 * e->u) << name << ": " << e->value << " ± " << e->u;
  }
}

// Over seeds the errors against the machine file are as their u say: at most a few of the terms beyond 3 u.
TEST(DbbGapsTest, SeedsStatistics) {
  if (!std::getenv("GUIDEWAY_SLOW_TESTS")) GTEST_SKIP() << "long variant: ctest -L slow (dbb_gaps_seeds)";
  int off = 0, terms = 0;
  double worst = 0;
  std::map<std::string, std::pair<double, double>> z;  // per term: sum of z, of z^2
  constexpr int seeds = 20;
  for (std::uint64_t seed = 1; seed <= seeds; ++seed) {
    const auto id = models::dbb::identify(with_live_like_gaps(standard_test(100 + 2 * seed), seed));
    const Check c = check_against_truth(id, false);
    off += c.off;
    terms += static_cast<int>(example_machine_truth().size());
    worst = std::max(worst, c.worst_z);
    for (const auto& [name, v] : c.z) {
      z[name].first += v;
      z[name].second += v * v;
    }
  }
  for (const auto& [name, s] : z)
    std::printf("  %-32s mean (value - truth) / u %+.2f, rms %.2f\n", name.c_str(), s.first / seeds,
                std::sqrt(s.second / seeds));
  std::printf("%d seeds: %d of %d terms beyond 3 u of the machine file, the worst %.2f u\n", seeds, off, terms, worst);
  EXPECT_LE(off, terms / 50);  // 0.27 % expected of normal errors; 2 % allowed
  EXPECT_LT(worst, 5.0);
}

}  // namespace
