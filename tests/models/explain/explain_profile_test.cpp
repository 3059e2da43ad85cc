// The flatness front end of EXPLAIN with Mu 2012 Eq. 16's measured straightness (profile_explain.cpp):
// the traverse's polynomial is subtracted from every profile, its slope is the abbe_offset column,
// abbe_offset is a candidate only when a traverse is given, and a traverse that does not cover the
// profiles (or one given to the straightness model) is refused with the files named. Synthetic profiles
// from a known carriage curve h(x) = 2e-3 x^2 + 0.1 x^3 (m), checked against that curve directly.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "models/explain/explain.hpp"
#include "models/explain/profile_explain.hpp"
#include "profile_test_support.hpp"
#include "simulators/machine/machine.hpp"

using namespace guideway;

namespace {

double h_m(double x_m) { return 2e-3 * x_m * x_m + 0.1 * x_m * x_m * x_m; }
double slope(double x_m) { return 4e-3 * x_m + 0.3 * x_m * x_m; }

// Noise-free chord slopes of h over [x0, x0 + 20 mm], 1 mm feet.
models::flatness::AngleTraverse traverse(double x0_m = 0.0) {
  models::flatness::AngleTraverse t;
  t.source = "t.csv";
  t.step_m = 1e-3;
  for (int k = 0; k < 20; ++k) {
    const double x = x0_m + k * 1e-3;
    t.x_m.push_back(x);
    t.pitch_rad.push_back(std::atan((h_m(x + 1e-3) - h_m(x)) / 1e-3));
    t.line.push_back(static_cast<std::size_t>(k + 3));
  }
  return t;
}

// Two cuts (2 and 8 mm/min): h + 5 urad squareness + abbe_mm * slope + 0.03 um noise.
std::vector<models::explain::ProfileRun> profiles(double abbe_mm, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.03e-6);
  return test::two_cuts([&](double x) { return h_m(x) + 5e-6 * x + abbe_mm * 1e-3 * slope(x) + noise(rng); });
}

bool has_candidate(const models::explain::Problem& p, const std::string& name) {
  return std::any_of(p.candidates.begin(), p.candidates.end(), [&](const auto& c) { return c.effect == name; });
}

}  // namespace

TEST(ExplainProfile, MeasuredStraightnessIsInTheBase) {
  const auto runs = profiles(0.0, 1);
  const auto tr = traverse();
  const models::explain::Problem with = models::explain::profile_problem(runs, "flatness", &tr);
  // The samples are the profile minus the traverse's curve: h is gone, only line + noise remain.
  double worst = 0;
  for (std::size_t i = 0; i < with.samples.size(); ++i) {
    const auto& s = with.samples[i];
    const std::size_t k = i % 201;  // 201 points per profile, in order
    worst = std::max(worst, std::abs(s.y_um - (runs[s.run].z_m[k] - h_m(runs[s.run].x_m[k])) * 1e6));
  }
  EXPECT_LT(worst, 1e-6);  // um: the polynomial of noise-free chord slopes is the curve itself
  ASSERT_FALSE(with.notes.empty());
  EXPECT_NE(with.notes.front().find("Eq. 16"), std::string::npos) << with.notes.front();
  EXPECT_TRUE(has_candidate(with, "abbe_offset"));
  const models::explain::Report r = models::explain::explain(with);
  EXPECT_TRUE(r.findings.empty());
  EXPECT_FALSE(r.unexplained);
  EXPECT_NEAR(r.baseline.rms_um, 0.03, 0.005);

  // Without the traverse: the bow stays in the residual and the output says why.
  const models::explain::Problem without = models::explain::profile_problem(runs, "flatness");
  EXPECT_FALSE(has_candidate(without, "abbe_offset"));
  ASSERT_FALSE(without.notes.empty());
  EXPECT_NE(without.notes.front().find("not supplied"), std::string::npos) << without.notes.front();
  EXPECT_GT(models::explain::explain(without).baseline.rms_um, 0.1);
}

TEST(ExplainProfile, AbbeColumnIsThePitchAndItsOffsetIsFound) {
  const auto tr = traverse();
  const models::explain::Problem p = models::explain::profile_problem(profiles(3.0, 2), "flatness", &tr);
  const auto c = std::find_if(p.candidates.begin(), p.candidates.end(), [](const auto& k) { return k.effect == "abbe_offset"; });
  ASSERT_NE(c, p.candidates.end());
  ASSERT_EQ(c->variants.size(), 1u);
  const auto& col = c->variants[0].block.columns;
  for (std::size_t i = 0; i < p.samples.size(); i += 37)
    EXPECT_NEAR(col(static_cast<Eigen::Index>(i), 0), slope(p.samples[i].where * 1e-3) * 1e3, 1e-6);
  const models::explain::Report r = models::explain::explain(p);
  ASSERT_FALSE(r.findings.empty());
  EXPECT_EQ(r.findings.front().effect, "abbe_offset");
  const auto& offset = r.findings.front().parameters.front();
  EXPECT_EQ(offset.name, "abbe_offset_x_mm");
  EXPECT_LT(offset.u, 0.3);
  EXPECT_NEAR(offset.value, 3.0, 3 * offset.u) << models::explain::to_text(r);  // only the pitch's curvature carries it
  EXPECT_LT(r.final_fit.heldout_rms_um, r.baseline.heldout_rms_um);
}

TEST(ExplainProfile, RefusesATraverseThatDoesNotFit) {
  const auto runs = profiles(0.0, 3);
  const auto shifted = traverse(5e-3);  // 5..25 mm: the profiles start at 0
  try {
    (void)models::explain::profile_problem(runs, "flatness", &shifted);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("t.csv"), std::string::npos) << m;
    EXPECT_NE(m.find("p1.csv"), std::string::npos) << m;
  }
  const auto tr = traverse();
  EXPECT_THROW((void)models::explain::profile_problem(runs, "straightness", &tr), std::invalid_argument);
}

// A faced profile from the virtual machine tool (0.8 mm nose, 20 um per revolution, 1 um profile steps,
// 0.02 um noise): the feed marks are a scallop with all its harmonics, so they are found with the nose
// radius, and their second harmonic is not taken for a twice-per-revolution spindle_axial_runout, which
// at constant feed falls at the same period. A real axial run-out in the path is found beside them.
namespace {

models::explain::Report explain_faced_cut(double axial_runout_m) {
  guideway::simulators::machine::MachineConfig c;
  c.noise.profilometer_m = 0.02e-6;
  c.spindle.axial_runout_m = axial_runout_m;
  const guideway::simulators::machine::Machine m{c};
  guideway::simulators::machine::FacingSpec f;
  f.x_start_m = 0.050;
  f.x_end_m = 0.054;
  f.feed_m_per_s = 2.0 / 60000.0;
  f.spindle_rpm = 100.0;
  f.tool_nose_radius_m = 0.8e-3;
  f.profile_step_m = 1e-6;
  f.runout_along_path = true;
  models::explain::ProfileRun r;
  r.source = "cut.csv";
  r.feed_mm_per_min = 2.0;
  r.spindle_rpm = 100.0;
  for (const auto& p : m.facing_profile(f)) {
    r.x_m.push_back(p.x_m);
    r.z_m.push_back(p.z_m);
    r.t_s.push_back(p.t_s);
  }
  return models::explain::explain(models::explain::profile_problem({r}, "straightness"));
}

const models::explain::ParamValue& param(const models::explain::Finding& f, const std::string& name) {
  for (const auto& p : f.parameters)
    if (p.name == name) return p;
  throw std::runtime_error("no parameter " + name);
}

}  // namespace

TEST(ExplainProfile, FeedMarksAreAScallopNotSpindleRunout) {
  const auto rep = explain_faced_cut(0.0);
  ASSERT_EQ(rep.findings.size(), 1u) << models::explain::to_text(rep);
  EXPECT_EQ(rep.findings[0].effect, "feed_marks");
  const auto& radius = param(rep.findings[0], "tool_nose_radius_mm");
  EXPECT_NEAR(radius.value, 0.8, std::max(3 * radius.u, 0.01)) << radius.u;
  const auto& a1 = param(rep.findings[0], "feed_marks_um");
  EXPECT_NEAR(a1.value, 0.020 * 0.020 / (2 * std::numbers::pi * std::numbers::pi * 0.8) * 1e3, 3 * a1.u);
  EXPECT_LT(rep.final_fit.heldout_rms_um, rep.baseline.heldout_rms_um);
}

TEST(ExplainProfile, AxialRunoutBesideTheFeedMarksIsFound) {
  const auto rep = explain_faced_cut(0.03e-6);
  std::vector<std::string> effects;
  for (const auto& f : rep.findings) effects.push_back(f.effect);
  ASSERT_NE(std::find(effects.begin(), effects.end(), "spindle_axial_runout"), effects.end())
      << models::explain::to_text(rep);
  ASSERT_NE(std::find(effects.begin(), effects.end(), "feed_marks"), effects.end()) << models::explain::to_text(rep);
  for (const auto& f : rep.findings) {
    if (f.effect != "spindle_axial_runout") continue;
    const auto& a = param(f, "spindle_axial_runout_um");
    EXPECT_NEAR(a.value, 0.03, std::max(3 * a.u, 0.003));
  }
}
