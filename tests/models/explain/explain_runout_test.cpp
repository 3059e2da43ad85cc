// EXPLAIN for spindle run-out records (models/explain/runout_explain) on the virtual machine's spindle:
// it finds each error the machine file holds, with its size within its uncertainty, and nothing it does
// not; a spindle with no error motion stays quiet; and the machine file's new [spindle] keys.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <string>

#include "models/explain/explain.hpp"
#include "models/explain/runout_explain.hpp"
#include "simulators/machine/machine.hpp"

namespace {

using namespace guideway;
using models::explain::Report;
using models::explain::RunoutRecord;

// 20 revolutions at 60 rpm read 50 times a second: the runout session's defaults on the default daemon.
// turned_deg: the plate turned on the table since the first record (a reversal; the record then states it).
RunoutRecord record_of(const simulators::machine::MachineConfig& cfg, std::uint64_t seed,
                       std::optional<double> turned_deg = std::nullopt) {
  simulators::machine::RunoutSpec spec;
  spec.rpm = 60.0;
  spec.samples_per_rev = 50;
  spec.revolutions = 20;
  spec.seed = seed;
  RunoutRecord r;
  if (turned_deg) {
    spec.artifact_turned_rad = *turned_deg * std::numbers::pi / 180.0;
    r.artifact_turned_rad = spec.artifact_turned_rad;
  }
  r.source = "virtual spindle";
  r.rpm = spec.rpm;
  for (const auto& s : simulators::machine::Machine(cfg).runout_revolution(spec)) {
    r.angle_rad.push_back(2 * std::numbers::pi * spec.rpm / 60.0 * s.t_s);  // from time, as the session does
    r.runout_m.push_back(s.displacement_m);
  }
  return r;
}

// finding effect (with its order for lines) -> its parameters by name
std::map<std::string, std::map<std::string, models::explain::ParamValue>> findings(const Report& rep) {
  std::map<std::string, std::map<std::string, models::explain::ParamValue>> out;
  for (const auto& f : rep.findings) {
    std::string key = f.effect;
    std::map<std::string, models::explain::ParamValue> params;
    for (const auto& p : f.parameters) {
      params[p.name] = p;
      if (p.name == "order_per_rev") key += " " + std::to_string(p.value).substr(0, 4);
    }
    out[key] = params;
  }
  return out;
}

std::string names(const Report& rep) {
  std::string s;
  for (const auto& [k, v] : findings(rep)) s += k + "; ";
  return s;
}

TEST(ExplainRunout, FindsWhatTheExampleMachineSpindleHolds) {
  // config/machine-example.toml: axial_runout 0.05 um (order 2), a 3rd harmonic 0.12 um, a line at 3.7 per
  // revolution 0.08 um, axial growth 0.3 um/min, the lean and the plate (the base's once per revolution).
  const auto cfg = simulators::machine::default_machine_config();
  ASSERT_EQ(cfg.spindle.synchronous.size(), 1u);
  ASSERT_EQ(cfg.spindle.asynchronous.size(), 1u);
  for (std::uint64_t seed : {1u, 2u}) {
    const Report rep = models::explain::explain_runout({record_of(cfg, seed)});
    const auto f = findings(rep);
    ASSERT_EQ(f.size(), 4u) << names(rep);
    const auto near = [&](const std::string& effect, const std::string& name, double truth) {
      ASSERT_TRUE(f.count(effect)) << effect << " not in " << names(rep);
      const auto& p = f.at(effect).at(name);
      EXPECT_LT(std::abs(p.value - truth), std::max(4 * p.u, 1e-3))
          << effect << " " << name << " " << p.value << " +/- " << p.u << " (truth " << truth << ")";
    };
    near("synchronous_harmonic 2.00", "synchronous_harmonic_um", 0.05);
    near("synchronous_harmonic 3.00", "synchronous_harmonic_um", 0.12);
    // The reading is the plate's height under the probe: the spindle's motion along +z with its sign
    // reversed. -cos(3 theta + 40 deg) = sin(3 theta + 40 deg - 90 deg).
    near("synchronous_harmonic 3.00", "synchronous_harmonic_phase_deg", 40.0 - 90.0);
    near("asynchronous_line 3.70", "asynchronous_line_um", 0.08);
    near("thermal_drift", "axial_growth_um_per_min", -0.3);
    EXPECT_LT(rep.final_fit.heldout_rms_um, 0.5 * rep.baseline.heldout_rms_um);
    EXPECT_FALSE(rep.unexplained);
  }
}

TEST(ExplainRunout, ASpindleWithoutErrorMotionStaysQuietAndASpeedRampIsNamed) {
  simulators::machine::MachineConfig cfg;
  cfg.spindle.tilt_x_rad = 2.8e-6;
  cfg.spindle.plate_parallelism_rad = 2.5e-6;
  cfg.noise.micrometer_m = 0.01e-6;
  for (std::uint64_t seed : {3u, 4u}) {
    const Report rep = models::explain::explain_runout({record_of(cfg, seed)});
    EXPECT_TRUE(rep.findings.empty()) << names(rep);
    EXPECT_FALSE(rep.unexplained);
  }
  cfg.spindle.speed_ramp_per_s = 0.03 / 60.0;  // 3 %/min
  const Report rep = models::explain::explain_runout({record_of(cfg, 5)});
  const auto f = findings(rep);
  ASSERT_EQ(f.size(), 1u) << names(rep);
  const auto& ramp = f.at("speed_variation").at("speed_ramp_percent_per_min");
  EXPECT_LT(std::abs(ramp.value - 3.0), 4 * ramp.u) << ramp.value << " +/- " << ramp.u;
}

// Donaldson's reversal: a 3-lobed race on the spindle under a plate with 3 and 5 lobes of its own, two
// records with the plate turned 180 deg between them, both from the spindle's zero (an index).
TEST(ExplainRunout, AReversalTellsTheSpindlesHarmonicFromThePlatesForm) {
  simulators::machine::MachineConfig cfg;
  cfg.spindle.tilt_x_rad = 2.8e-6;
  cfg.spindle.plate_parallelism_rad = 2.5e-6;
  cfg.spindle.synchronous = {{3, 0.08e-6, 0.3}};
  cfg.spindle.plate_form = {{3, 0.05e-6, 1.2}, {5, 0.04e-6, -0.4}};
  cfg.noise.micrometer_m = 0.01e-6;
  const Report rep = models::explain::explain_runout({record_of(cfg, 7, 0.0), record_of(cfg, 8, 180.0)});
  const auto f = findings(rep);
  ASSERT_EQ(f.size(), 3u) << names(rep);
  const auto near = [&](const std::string& effect, const std::string& name, double truth) {
    ASSERT_TRUE(f.count(effect)) << effect << " not in " << names(rep);
    const auto& p = f.at(effect).at(name);
    EXPECT_LT(std::abs(p.value - truth), 4 * p.u)
        << effect << " " << p.value << " +/- " << p.u << " (truth " << truth << ")";
    if (name.ends_with("_um")) {
      EXPECT_LT(p.u, 0.005) << effect;
    }
  };
  near("synchronous_harmonic 3.00", "synchronous_harmonic_um", 0.08);
  near("artifact_form 3.00", "artifact_form_harmonic_um", 0.05);
  near("artifact_form 5.00", "artifact_form_harmonic_um", 0.04);
  // The form's phase from the spindle's zero in the first record: +cos(5 theta - 0.4 rad) = sin(5 theta - 0.4 + pi/2).
  near("artifact_form 5.00", "artifact_form_harmonic_phase_deg", -0.4 * 180 / std::numbers::pi + 90.0);
  const auto noted = [&](const Report& r, const std::string& what) {
    return std::any_of(r.notes.begin(), r.notes.end(),
                       [&](const std::string& n) { return n.find(what) != std::string::npos; });
  };
  EXPECT_TRUE(noted(rep, "orders 2, 4, 6")) << "even orders stay together";

  // The same records with no turn stated: the harmonics stay together, one phase per record.
  RunoutRecord a = record_of(cfg, 7), b = record_of(cfg, 8, 180.0);
  b.artifact_turned_rad.reset();
  const Report together = models::explain::explain_runout({a, b});
  for (const auto& finding : together.findings) EXPECT_NE(finding.effect, "artifact_form") << names(together);
  // A turn stated on records whose angles start at their first reading (the live session's): refused, noted.
  a = record_of(cfg, 7, 0.0);
  b = record_of(cfg, 8, 180.0);
  b.angle_from_spindle_zero = false;
  const Report refused = models::explain::explain_runout({a, b});
  for (const auto& finding : refused.findings) EXPECT_NE(finding.effect, "artifact_form") << names(refused);
  EXPECT_TRUE(noted(refused, "no reversal")) << names(refused);
}

TEST(ExplainRunout, ASpeedRippleIsNamedWithItsSize) {
  simulators::machine::MachineConfig cfg;
  cfg.spindle.tilt_x_rad = 2.8e-6;
  cfg.spindle.plate_parallelism_rad = 0.8e-6;  // a 1 um lean: its phase wobbles with the ripple
  cfg.spindle.speed_ripple = 0.01;
  cfg.spindle.speed_ripple_per_rev = 0.4;
  cfg.noise.micrometer_m = 0.01e-6;
  const Report rep = models::explain::explain_runout({record_of(cfg, 9)});
  const auto f = findings(rep);
  ASSERT_EQ(f.size(), 1u) << names(rep);
  ASSERT_TRUE(f.count("speed_ripple 0.40") || f.count("speed_ripple 0.39")) << names(rep);
  const auto& ripple = f.begin()->second.at("speed_ripple_percent");
  EXPECT_LT(std::abs(ripple.value - 1.0), std::max(4 * ripple.u, 0.05)) << ripple.value << " +/- " << ripple.u;
}

TEST(ExplainRunout, RefusesARecordOfLessThanTwoRevolutions) {
  simulators::machine::MachineConfig cfg;
  RunoutRecord r = record_of(cfg, 1);
  r.angle_rad.resize(60);
  r.runout_m.resize(60);
  try {
    (void)models::explain::explain_runout({r});
    FAIL() << "a record of 1.2 revolutions was explained";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("1 whole revolutions"), std::string::npos) << e.what();
  }
}

TEST(MachineSpindle, ReadsTheErrorMotionKeysAndRefusesMisplacedOrders) {
  const auto c = simulators::machine::parse_machine_config(
      "[spindle]\nharmonic_orders = [2, 5]\nharmonic_um = [0.1, 0.2]\nharmonic_phase_deg = [0, 90]\n"
      "async_orders = [0.43]\nasync_um = [0.05]\naxial_growth_um_per_min = 0.6\nspeed_ramp_percent_per_min = 1.5\n",
      "m.toml");
  ASSERT_EQ(c.spindle.synchronous.size(), 2u);
  EXPECT_DOUBLE_EQ(c.spindle.synchronous[1].order, 5.0);
  EXPECT_DOUBLE_EQ(c.spindle.synchronous[1].amplitude_m, 0.2e-6);
  EXPECT_DOUBLE_EQ(c.spindle.synchronous[1].phase_rad, std::numbers::pi / 2);
  ASSERT_EQ(c.spindle.asynchronous.size(), 1u);
  EXPECT_DOUBLE_EQ(c.spindle.asynchronous[0].phase_rad, 0.0);  // phases default to 0
  EXPECT_DOUBLE_EQ(c.spindle.axial_growth_m_per_s, 0.01e-6);
  EXPECT_DOUBLE_EQ(c.spindle.speed_ramp_per_s, 0.015 / 60.0);
  const auto d = simulators::machine::parse_machine_config(
      "[spindle]\nplate_form_orders = [3]\nplate_form_um = [0.05]\nspeed_ripple_percent = 2\nspeed_ripple_per_rev = "
      "0.4\n",
      "m.toml");
  ASSERT_EQ(d.spindle.plate_form.size(), 1u);
  EXPECT_DOUBLE_EQ(d.spindle.plate_form[0].amplitude_m, 0.05e-6);
  EXPECT_DOUBLE_EQ(d.spindle.speed_ripple, 0.02);
  EXPECT_DOUBLE_EQ(d.spindle.speed_ripple_per_rev, 0.4);
  const auto refused = [](const std::string& toml, const std::string& why) {
    try {
      (void)simulators::machine::parse_machine_config(toml, "m.toml");
      ADD_FAILURE() << "accepted: " << toml;
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  refused("[spindle]\nharmonic_orders = [2.5]\nharmonic_um = [0.1]\n", "whole numbers from 2");
  refused("[spindle]\nharmonic_orders = [1]\nharmonic_um = [0.1]\n", "whole numbers from 2");
  refused("[spindle]\nasync_orders = [4]\nasync_um = [0.1]\n", "not whole numbers");
  refused("[spindle]\nasync_orders = [3.7]\nasync_um = []\n", "one amplitude per order");
  refused("[spindle]\nplate_form_orders = [2.5]\nplate_form_um = [0.1]\n", "whole numbers from 2");
  refused("[spindle]\nspeed_ripple_percent = 1\n", "its frequency");
}

// The plate's form turns with the plate, the spindle's error motion does not: half a turn flips the odd
// orders of the form and leaves the rest of the reading where it was.
TEST(MachineSpindle, ThePlatesFormTurnsWithThePlate) {
  simulators::machine::MachineConfig cfg = simulators::machine::default_machine_config();
  cfg.noise.micrometer_m = 0;
  cfg.spindle.plate_form = {{3, 0.05e-6, 1.2}, {4, 0.03e-6, 0.0}};
  simulators::machine::RunoutSpec spec;
  spec.rpm = 60;
  spec.samples_per_rev = 50;
  spec.revolutions = 1;
  const auto a = simulators::machine::Machine(cfg).runout_revolution(spec);
  spec.artifact_turned_rad = std::numbers::pi;
  const auto b = simulators::machine::Machine(cfg).runout_revolution(spec);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k)
    EXPECT_NEAR(a[k].displacement_m - b[k].displacement_m, 2 * 0.05e-6 * std::cos(3 * a[k].angle_rad + 1.2), 1e-15)
        << k;
}

TEST(MachineSpindle, AReadingAloneEqualsTheSameReadingInARecord) {
  const simulators::machine::Machine m(simulators::machine::default_machine_config());
  simulators::machine::RunoutSpec spec;
  spec.rpm = 60;
  spec.samples_per_rev = 50;
  spec.revolutions = 3;
  const auto rec = m.runout_revolution(spec);
  ASSERT_EQ(rec.size(), 150u);
  for (std::uint64_t k : {0u, 77u, 149u}) {
    const auto s = m.runout_sample(spec, k);
    EXPECT_EQ(s.displacement_m, rec[k].displacement_m);
    EXPECT_EQ(s.t_s, rec[k].t_s);
  }
}

}  // namespace
