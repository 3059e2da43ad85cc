// docs/conventions.md, "Why the daemon's default session reports squareness 86 urad": with patterns
// at h > 0 the roll of Y (Lai's c1) has the squareness signature, (h / L0) c1 r^2 sin cos, so the
// in-plane ballbar diagnostics report a least-squares compromise of squareness and servo mismatch.
// Checked against that compromise computed independently from the run geometry, and against the
// configured squareness from an h = 0 ccw/cw pair.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "dbb_test_support.hpp"

namespace {

using namespace guideway;

constexpr double q_true = 30e-6;   // squareness (rad)
constexpr double c1 = 2.5e-3;      // Lai's c1 of the default machine: 2.5 urad/mm = 2.5e-3 rad/m

sim::Machine roll_machine() {
  sim::MachineConfig m;
  m.noise.seed = 7;
  m.dbb.noise_m = 0.1e-6;
  m.squareness.xy = q_true;
  m.axis[1].rotation[1].c = {0.0, -c1};  // rotation about +y of -c(y): n displacement x * c1 * y
  return sim::Machine{m};
}

struct Pattern {
  double r_mm, h_mm;
  bool ccw;
};

TEST(DbbHAliasing, SquarenessIsTheCompromiseOfTheTable4Patterns) {
  const auto m = roll_machine();
  const Pattern table4[] = {{95, 31.225, true}, {95, 31.225, false}, {100, 0, true}};
  std::vector<models::dbb::Run> runs;
  std::uint64_t seed = 1;
  for (const auto& p : table4) runs.push_back(test::lai_pattern(m, p.r_mm, p.h_mm, p.ccw, seed++));
  const auto d = test::by_name(models::dbb::identify(runs).diagnostics);

  // Per run the sin-cos amplitude (m) is lambda r q + (h / L0) c1 r^2 (+ lambda dir v dtau); one q and
  // one dtau fitted to the three amplitudes with equal weight (equal point counts).
  Eigen::MatrixXd a(3, 2);
  Eigen::VectorXd b(3);
  for (int k = 0; k < 3; ++k) {
    const double r = table4[k].r_mm * 1e-3, h = table4[k].h_mm * 1e-3, l0 = std::hypot(r, h);
    const double v = runs[static_cast<std::size_t>(k)].feed_m_per_s;
    a(k, 0) = r / l0 * r;
    a(k, 1) = r / l0 * (table4[k].ccw ? 1.0 : -1.0) * v;
    b[k] = r / l0 * r * q_true + h / l0 * c1 * r * r;
  }
  const Eigen::Vector2d x = a.colPivHouseholderQr().solve(b);
  const double q_expected_urad = x[0] * 1e6, dtau_expected_ms = x[1] * 1e3;
  EXPECT_NEAR(q_expected_urad, 86.0, 0.5);  // the figure docs/conventions.md explains
  EXPECT_NEAR(d.at("squareness_urad").value, q_expected_urad, 0.2 + 3 * d.at("squareness_urad").u);
  EXPECT_NEAR(d.at("servo_mismatch_ms").value, dtau_expected_ms, 0.002 + 3 * d.at("servo_mismatch_ms").u);
}

TEST(DbbHAliasing, AnInPlanePairReportsTheConfiguredSquareness) {
  const auto m = roll_machine();
  std::vector<models::dbb::Run> runs{test::lai_pattern(m, 100, 0, true, 11), test::lai_pattern(m, 100, 0, false, 12)};
  const auto d = test::by_name(models::dbb::identify(runs).diagnostics);
  EXPECT_NEAR(d.at("squareness_urad").value, q_true * 1e6, 3 * d.at("squareness_urad").u + 0.1);
  EXPECT_NEAR(d.at("servo_mismatch_ms").value, 0.0, 3 * d.at("servo_mismatch_ms").u + 0.002);
}

}  // namespace
