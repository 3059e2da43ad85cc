// Squareness from a spindle run-out revolution (models/flatness/runout, Mu 2012 Eq. 21): the paper's
// numbers, a revolution from the virtual machine tool, uncertainty coverage and bad-input messages.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>

#include "models/flatness/runout.hpp"
#include "core/csv_table.hpp"
#include "simulators/machine/machine.hpp"
#include "test_support.hpp"

namespace {

using namespace guideway::models::flatness;
constexpr double pi = std::numbers::pi;

// A revolution file: offset + A cos(phi - phase) + 2nd harmonic + noise, 360 samples.
std::string revolution_csv(double amplitude_um, double phase_deg, double noise_um, std::uint64_t seed,
                           const std::string& extra_meta = "# travel_mm = 600\n") {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, noise_um);
  std::ostringstream out;
  out.precision(12);
  out << "# plate_diameter_mm = 1000\n# parallelism_um = 2.5\n" << extra_meta << "angle_deg,runout_um\n";
  for (int k = 0; k < 360; ++k) {
    const double phi = k * pi / 180.0;
    out << k << ","
        << 1.2 + amplitude_um * std::cos(phi - phase_deg * pi / 180.0) + 0.04 * std::cos(2 * phi + 0.3) + g(rng)
        << "\n";
  }
  return out.str();
}

TEST(FlatnessRunout, ReproducesMuEquation21) {
  // r = 0.3 um peak to peak (A = 0.15 um), p = 2.5 um, L = 1000 mm, travel 600 mm.
  const auto rev = parse_runout_revolution(revolution_csv(0.15, 40.0, 0.01, 3), "rev.csv");
  const auto r = identify_runout(rev);
  EXPECT_NEAR(r.runout_m, 0.3e-6, 3 * r.u_runout_m);
  EXPECT_NEAR(r.phase_rad, 40.0 * pi / 180.0, 3 * r.u_phase_rad);
  EXPECT_NEAR(r.second_harmonic_m, 0.04e-6, 0.01e-6);
  // Paper: 2.8e-6 rad and 1.7e-3 mm (two significant figures).
  EXPECT_NEAR(r.deflection_rad, 2.8e-6, 0.05e-6);
  ASSERT_TRUE(r.squareness_amplitude_m.has_value());
  EXPECT_NEAR(*r.squareness_amplitude_m, 1.7e-6, 0.05e-6);
  EXPECT_NEAR(*r.squareness_amplitude_m, r.deflection_rad * 0.6, 1e-18);
  // Exactly the paper's arithmetic with a noise-free revolution.
  const auto exact = identify_runout(parse_runout_revolution(revolution_csv(0.15, 40.0, 0.0, 1), "exact.csv"));
  EXPECT_NEAR(exact.runout_m, 0.3e-6, 1e-15);
  EXPECT_NEAR(exact.deflection_rad, 2.8e-6, 1e-15);
  EXPECT_NEAR(*exact.squareness_amplitude_m, 1.68e-6, 1e-15);
  std::printf(
      "Eq. 21: r = %.4f um (u %.4f), theta0 = %.4f urad (u %.4f), over 600 mm %.4f um (paper: 0.3 um, 2.8 urad, "
      "1.7 um)\n",
      r.runout_m * 1e6, r.u_runout_m * 1e6, r.deflection_rad * 1e6, r.u_deflection_rad * 1e6,
      *r.squareness_amplitude_m * 1e6);
}

TEST(FlatnessRunout, UncertaintyCoversTheTruthInRepeatedTrials) {
  int amp = 0, phase = 0;
  const int trials = 1000;
  for (int i = 0; i < trials; ++i) {
    const auto r = identify_runout(
        parse_runout_revolution(revolution_csv(0.15, 200.0, 0.05, 1000 + static_cast<std::uint64_t>(i)), "t.csv"));
    amp += std::abs(r.amplitude_m - 0.15e-6) <= 2 * r.u_amplitude_m;
    double dp = std::remainder(r.phase_rad - 200.0 * pi / 180.0, 2 * pi);
    phase += std::abs(dp) <= 2 * r.u_phase_rad;
  }
  std::printf("run-out coverage within 2u over %d trials: amplitude %.3f, phase %.3f\n", trials,
              static_cast<double>(amp) / trials, static_cast<double>(phase) / trials);
  EXPECT_GE(amp, 0.92 * trials);
  EXPECT_LE(amp, 0.98 * trials);
  EXPECT_GE(phase, 0.92 * trials);
  EXPECT_LE(phase, 0.98 * trials);
}

// The virtual machine tool as in Mu's Sec. 4: the spindle leans by 2.8 urad, the thrust plate by
// 2.5 urad the same way (so r = 0.3 um on a 1 m plate, probe at the rim, and Eq. 21 gives 2.8 urad), with axial run-out and micrometer noise; the file round trip recovers r.
// Spindle and plate leaning by `spindle_rad` and `plate_rad` towards the azimuth `direction_rad`.
void lean(guideway::simulators::machine::MachineConfig& c, double spindle_rad, double plate_rad, double direction_rad) {
  c.spindle.tilt_x_rad = spindle_rad * std::cos(direction_rad);
  c.spindle.tilt_y_rad = spindle_rad * std::sin(direction_rad);
  c.spindle.plate_parallelism_rad = plate_rad;
  c.spindle.plate_parallelism_direction_rad = direction_rad;
}

TEST(FlatnessRunout, RecoversTheVirtualMachineSpindleLean) {
  using namespace guideway::simulators::machine;
  MachineConfig c;
  lean(c, 2.8e-6, 2.5e-6, 1.0);
  c.spindle.axial_runout_m = 0.05e-6;
  c.noise.micrometer_m = 0.01e-6;
  const Machine m{c};
  RunoutSpec spec;
  spec.probe_radius_m = 0.5;
  spec.samples_per_rev = 720;
  const auto samples = m.runout_revolution(spec);
  guideway::test::TempDir dir;
  const std::string file = dir.file("runout.csv");
  {
    std::ofstream out(file);
    out.precision(17);
    out << "# plate_diameter_mm = 1000\n# parallelism_um = 2.5\n# travel_mm = 600\nangle_deg,runout_um\n";
    for (const auto& s : samples) out << s.angle_rad * 180 / pi << "," << s.displacement_m * 1e6 << "\n";
  }
  const auto r = identify_runout(read_runout_revolution(file));
  EXPECT_NEAR(r.runout_m, 0.3e-6, 3 * r.u_runout_m + 1e-10);
  EXPECT_NEAR(r.second_harmonic_m, 0.05e-6, 0.005e-6);
  EXPECT_NEAR(r.deflection_rad, 2.8e-6, 3 * r.u_deflection_rad + 1e-10);
  EXPECT_NEAR(r.phase_rad, 1.0, 4 * r.u_phase_rad);  // towards the lean (this draw: 3.1u; exact without noise)
  std::printf("virtual machine: r = %.4f um (u %.4f, configured 2.8 - 2.5 urad over 1 m), theta0 = %.4f urad\n", r.runout_m * 1e6,
              r.u_runout_m * 1e6, r.deflection_rad * 1e6);
}

// Repeated revolutions of the virtual machine tool (new micrometer noise each): the run-out r covers
// the configured relative lean within 2u in about 95 % of the revolutions.
TEST(FlatnessRunout, VirtualMachineCoverageInRepeatedRevolutions) {
  using namespace guideway::simulators::machine;
  MachineConfig c;
  lean(c, 2.8e-6, 2.5e-6, 0.4);
  c.spindle.axial_runout_m = 0.05e-6;
  c.noise.micrometer_m = 0.02e-6;
  const Machine m{c};
  RunoutSpec spec;
  spec.probe_radius_m = 0.5;
  spec.samples_per_rev = 360;
  const int trials = 400;
  int hit = 0;
  for (int i = 0; i < trials; ++i) {
    spec.seed = 500 + static_cast<std::uint64_t>(i);
    RunoutRevolution rev;
    rev.source = "machine";
    rev.plate_diameter_m = 1.0;
    for (const auto& s : m.runout_revolution(spec)) {
      rev.angle_rad.push_back(s.angle_rad);
      rev.runout_m.push_back(s.displacement_m);
    }
    const auto r = identify_runout(rev);
    hit += std::abs(r.runout_m - 0.3e-6) <= 2 * r.u_runout_m;
  }
  std::printf("virtual machine, %d revolutions: run-out coverage within 2u %.3f\n", trials,
              static_cast<double>(hit) / trials);
  EXPECT_GE(hit, 0.9 * trials);
  EXPECT_LE(hit, 0.99 * trials);
}

std::string error_of(const std::string& text) {
  try {
    (void)identify_runout(parse_runout_revolution(text, "r.csv"));
  } catch (const guideway::CsvError& e) {
    return e.what();
  }
  return "no error";
}

TEST(FlatnessRunout, BadInputNamesFileAndLine) {
  std::string good = revolution_csv(0.15, 0, 0, 1, "");
  std::string bad = good;
  bad.replace(bad.find("\n5,") + 3, 3, "x.y");
  const std::string msg = error_of(bad);
  EXPECT_EQ(msg.substr(0, 33), "r.csv:9: column 'runout_um': 'x.y") << msg;
  EXPECT_EQ(msg.substr(msg.size() - 24), "' is not a finite number") << msg;
  EXPECT_EQ(error_of("# parallelism_um = 2.5\nangle_deg,runout_um\n0,1\n"),
            "r.csv: missing metadata line '# plate_diameter_mm = <number>'");
  EXPECT_EQ(error_of("# plate_diameter_mm = 1000\n# parallelism_um = 2.5\nangle_deg,runout_um\n0,1\n1,2\n"),
            "r.csv: 2 samples; a run-out revolution needs at least 8");
  std::string arc = "# plate_diameter_mm = 1000\n# parallelism_um = 2.5\nangle_deg,runout_um\n";
  for (int k = 0; k < 20; ++k) arc += std::to_string(k * 0.01) + ",0.1\n";
  EXPECT_NE(error_of(arc).find("do not determine a once- and twice-per-revolution sine"), std::string::npos)
      << error_of(arc);
}

}  // namespace
