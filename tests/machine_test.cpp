// The virtual machine tool: exact geometry, servo effects, TOML loading, reproducibility.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/toml_access.hpp"
#include "simulators/machine/machine.hpp"

namespace {

using namespace guideway::sim;

constexpr double pi = std::numbers::pi;

TEST(MachineTest, PerfectMachineTracesThePerfectCircle) {
  Machine m{MachineConfig{}};
  DbbCircleSpec spec;
  spec.radius_m = 0.1;
  spec.height_m = 0.03;
  const DbbRun run = m.dbb_circle(spec);
  ASSERT_GT(run.samples.size(), 3600u);
  for (const auto& s : run.samples) EXPECT_NEAR(s.dL_m, 0.0, 1e-12);
}

TEST(MachineTest, SquarenessFollowsTheIssueSignConvention) {
  MachineConfig c;
  c.squareness.xy = 100e-6;
  Machine m{c};
  // actual (x, y) = (x + q y, y)
  const Vec3 p = m.tool_point({0.0, 0.1, 0.0});
  EXPECT_NEAR(p[0], 100e-6 * 0.1, 1e-12);
  DbbCircleSpec spec;
  spec.radius_m = 0.1;
  const DbbRun run = m.dbb_circle(spec);
  for (const auto& s : run.samples) {
    EXPECT_NEAR(s.dL_m, 0.1 * 100e-6 * std::sin(s.angle_rad) * std::cos(s.angle_rad), 2e-9);
  }
}

TEST(MachineTest, LoadsTomlAndRejectsUnknownKeys) {
  const auto cfg = parse_machine_config("[axis.x]\nscale_ppm = 10\ne_y_um = [0, 0, 2.25e-4]\n", "m.toml");
  EXPECT_NEAR(cfg.axis[0].scale, 10e-6, 1e-18);
  EXPECT_NEAR(cfg.axis[0].translation[1](0.1), 2.25e-4 * 1e-6 * 100 * 100, 1e-15);
  try {
    (void)parse_machine_config("[axis.x]\nscale_pmm = 10\n", "m.toml");
    FAIL() << "unknown key accepted";
  } catch (const guideway::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("m.toml:2: axis.x.scale_pmm: unknown key"), std::string::npos) << e.what();
  }
}

}  // namespace
