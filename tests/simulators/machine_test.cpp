// The virtual machine tool: exact geometry, servo effects, TOML loading, reproducibility.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/toml_access.hpp"
#include "simulators/machine/machine.hpp"

namespace {

using namespace guideway::simulators::machine;

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

namespace {

using namespace guideway::simulators::machine;

TEST(MachineTest, SameSeedSameRunOtherSeedOtherNoise) {
  MachineConfig c;
  c.dbb.noise_m = 0.1e-6;
  Machine m{c};
  DbbCircleSpec s;
  s.seed = 5;
  const auto a = m.dbb_circle(s), b = m.dbb_circle(s);
  s.seed = 6;
  const auto d = m.dbb_circle(s);
  ASSERT_EQ(a.samples.size(), b.samples.size());
  bool differs = false;
  for (std::size_t i = 0; i < a.samples.size(); ++i) {
    EXPECT_EQ(a.samples[i].dL_m, b.samples[i].dL_m);
    differs |= a.samples[i].dL_m != d.samples[i].dL_m;
  }
  EXPECT_TRUE(differs);
}

TEST(MachineTest, DbbRunHasOvershootArcsAndAFullDataArc) {
  Machine m{MachineConfig{}};
  DbbCircleSpec s;
  s.direction = guideway::formats::DbbDirection::cw;
  s.sample_rate_hz = 200;
  const auto run = m.dbb_circle(s);
  double first = 0, last = 0;
  bool seen = false;
  for (const auto& x : run.samples) {
    if (!x.in_data_arc) continue;
    if (!seen) first = x.angle_rad;
    seen = true;
    last = x.angle_rad;
  }
  EXPECT_NEAR(first - last, 2 * pi, 0.01);  // cw: the angle decreases
  EXPECT_NEAR(run.samples.front().angle_rad, pi / 4, 1e-12);
  EXPECT_NEAR(run.nominal_length_m, 0.1, 1e-15);
}

TEST(MachineTest, ServoLagAndBacklashOnALinearMove) {
  MachineConfig c;
  c.axis[0].servo_lag_s = 0.03;
  c.axis[0].backlash_m = 4e-6;
  Machine m{c};
  const double v = 0.01;  // 600 mm/min
  const auto motion = m.simulate_motion({linear_move({0, 0, 0}, {0.02, 0, 0}, v), 1.0, 1000.0});
  // Steady state of a first-order loop following a ramp: lag v * tau behind the command.
  const auto& mid = motion[1000];
  EXPECT_NEAR(mid.commanded[0] - mid.encoder[0], v * 0.03, 1e-9);
  // Lost motion: the carriage trails the drive by half the backlash while moving +x.
  EXPECT_NEAR(mid.encoder[0] - mid.axis_actual[0], 2e-6, 1e-12);
  EXPECT_NEAR(mid.tool[0], mid.axis_actual[0], 1e-15);
}

TEST(MachineTest, EncoderQuantisation) {
  MachineConfig c;
  c.axis[1].encoder_resolution_m = 1e-6;
  Machine m{c};
  const auto motion = m.simulate_motion({linear_move({0, 0, 0}, {0, 0.0000137, 0}, 0.001), 0.1, 100.0});
  EXPECT_NEAR(motion.back().encoder[1], 14e-6, 1e-15);
}

TEST(MachineTest, AutocollimatorSeesTheSlopeOfABentGuideway) {
  MachineConfig c;
  c.axis[0].translation[1].c = {0, 0, 1e-6};   // y = 1e-6 x^2 (m): yaw = atan(2e-6 x)
  c.axis[0].translation[2].c = {0, 0, -2e-6};  // z = -2e-6 x^2: pitch about +y = atan(4e-6 x)
  c.axis[0].bending = true;
  Machine m{c};
  TraverseSpec t;
  t.start_m = 0;
  t.end_m = 0.6;
  t.step_m = 0.1;
  const auto st = m.autocollimator_traverse(t);
  ASSERT_EQ(st.size(), 7u);
  for (const auto& s : st) {
    EXPECT_NEAR(s.yaw_rad, std::atan(2e-6 * s.position_m), 1e-15);
    EXPECT_NEAR(s.pitch_rad, std::atan(4e-6 * s.position_m), 1e-15);
    EXPECT_NEAR(s.tool[1], 1e-6 * s.position_m * s.position_m, 1e-15);
  }
}

TEST(MachineTest, AngularErrorsMakeAbbeErrorsThroughTheToolOffset) {
  MachineConfig c;
  c.axis[0].rotation[1].c = {10e-6};  // X pitch: 10 urad about +y
  c.tool_offset = {0, 0, -0.1};       // tool point 100 mm below the carriage reference
  Machine m{c};
  const Vec3 p = m.tool_point({0.2, 0, 0});
  EXPECT_NEAR(p[0], 0.2 - 0.1 * std::sin(10e-6), 1e-15);  // Ry(b) (0, 0, -L) = (-L sin b, 0, -L cos b)
  EXPECT_NEAR(p[2], -0.1 * std::cos(10e-6), 1e-15);
  const auto r = m.carriage_rotation(Axis::x, {0.2, 0, 0});
  EXPECT_NEAR(r[2], std::sin(10e-6), 1e-18);
}

TEST(MachineTest, ThermalDriftGrowsWithTime) {
  MachineConfig c;
  c.axis[2].drift_m_per_s = 5e-6 / 3600;
  c.axis[0].scale_drift_per_s = 10e-6 / 3600;
  Machine m{c};
  const Vec3 p = m.tool_point({0.1, 0, 0}, 3600.0);
  EXPECT_NEAR(p[2], 5e-6, 1e-15);
  EXPECT_NEAR(p[0], 0.1 * (1 + 10e-6), 1e-15);
}

TEST(MachineTest, RunoutSeesTheSpindleLeanRelativeToThePlate) {
  MachineConfig c;
  c.spindle.tilt_x_rad = 0.5e-6;
  c.spindle.plate_parallelism_rad = 0.2e-6;
  Machine m{c};
  RunoutSpec s;
  s.probe_radius_m = 0.5;
  const auto rev = m.runout_revolution(s);
  ASSERT_EQ(rev.size(), 360u);
  double lo = 1, hi = -1;
  for (const auto& x : rev) {
    lo = std::min(lo, x.displacement_m);
    hi = std::max(hi, x.displacement_m);
  }
  // The probe circles perpendicular to the leaning axis; the plate leans the same way by less.
  EXPECT_NEAR(hi - lo, 2 * 0.5 * std::tan(0.3e-6), 1e-12);
  EXPECT_NEAR(rev[0].displacement_m, 0.5 * std::tan(0.3e-6), 1e-12);  // widest gap with the probe at +x
  // A lean towards +y peaks a quarter turn later; a plate leaning exactly like the spindle shows nothing.
  c.spindle.tilt_x_rad = 0;
  c.spindle.tilt_y_rad = 0.5e-6;
  c.spindle.plate_parallelism_direction_rad = std::numbers::pi / 2;
  const auto rev_y = Machine{c}.runout_revolution(s);
  EXPECT_NEAR(rev_y[90].displacement_m, 0.5 * std::tan(0.3e-6), 1e-12);
  EXPECT_NEAR(rev_y[0].displacement_m, 0.0, 1e-15);
  c.spindle.plate_parallelism_rad = 0.5e-6;
  for (const auto& x : Machine{c}.runout_revolution(s)) EXPECT_NEAR(x.displacement_m, 0.0, 1e-15);
}

TEST(MachineTest, FacedProfileCarriesSquarenessStraightnessFeedMarksAndDrift) {
  MachineConfig c;
  c.spindle.tilt_x_rad = 2.8e-6;              // Mu: squareness of the cross slide to the spindle
  c.axis[0].translation[2].c = {0, 0, 1e-6};  // X straightness in z: 1e-6 x^2 (0.36 um at 600 mm)
  Machine m{c};
  FacingSpec f;
  f.x_end_m = 0.6;
  f.feed_m_per_s = 2.0 / 60000;
  f.spindle_rpm = 100;
  f.tool_nose_radius_m = 0.0008;
  f.profile_step_m = 0.001;  // a multiple of the feed per revolution (0.02 mm): the cusp tops
  const auto prof = m.facing_profile(f);
  ASSERT_EQ(prof.size(), 601u);
  for (const auto& p : prof) {
    const double expected = p.x_m * std::sin(2.8e-6) + 1e-6 * p.x_m * p.x_m;
    EXPECT_NEAR(p.z_m, expected, 1e-9);
  }
  EXPECT_NEAR(prof.back().t_s, 0.6 / f.feed_m_per_s, 1e-6);
  // Between two passes the round nose leaves a cusp of height f^2 / (8 R).
  f.x_end_m = 0.001;
  f.profile_step_m = 0.00001;  // half the feed per revolution
  c.spindle.tilt_x_rad = 0;
  c.axis[0].translation[2].c.clear();
  Machine flat{c};
  const auto cusp = flat.facing_profile(f);
  double hi = 0;
  for (const auto& p : cusp) hi = std::max(hi, p.z_m);
  const double fpr = 0.02e-3;
  EXPECT_NEAR(hi, 0.0008 - std::sqrt(0.0008 * 0.0008 - fpr * fpr / 4), 1e-12);
  // Thermal drift of Z over the 300 min cut tilts the profile.
  MachineConfig d;
  d.axis[2].drift_m_per_s = 1e-6 / 3600;
  Machine warm{d};
  f.x_end_m = 0.6;
  f.profile_step_m = 0.001;
  const auto drifted = warm.facing_profile(f);
  EXPECT_NEAR(drifted.back().z_m - drifted.front().z_m, 5e-6, 1e-9);  // 5 h at 1 um/h
}

TEST(MachineTest, ArtifactSeesTheSixErrorFunctions) {
  MachineConfig c;
  c.axis[0].translation[0].c = {0, 2e-6};  // positioning: 2 um/m
  c.axis[0].translation[1].c = {1e-6};
  c.axis[0].rotation[0].c = {3e-6};  // roll
  Machine m{c};
  ArtifactSpec a;
  const auto t = m.artifact_measurement(a);
  ASSERT_EQ(t.size(), 9u);
  EXPECT_NEAR(t[8].displacement_m[0], 2e-6 * 0.4, 1e-15);
  EXPECT_NEAR(t[8].displacement_m[1], 1e-6, 1e-15);
  EXPECT_NEAR(t[3].rotation_rad[0], 3e-6, 1e-15);
}

TEST(MachineTest, ExampleMachineFileLoads) {
  const auto cfg = load_machine_config(GUIDEWAY_SOURCE_DIR "/config/machine-example.toml");
  EXPECT_EQ(cfg.name, "example-vmc");
  EXPECT_NEAR(cfg.axis[1].backlash_m, 2e-6, 1e-15);
  try {
    (void)parse_machine_config("[axis.x]\nservo_lag_ms = \"fast\"\n", "m.toml");
    FAIL();
  } catch (const guideway::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("m.toml:2: axis.x.servo_lag_ms: expected a number, got a string"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
