// The error map's model, files and formats (models/map, formats/iso230_tables, docs/map.md): the chain against
// the virtual machine's, its derivatives, the gauge, the ISO 230-1 tables, the artifact and the traverse on any
// axis, the day's manifest, what a partial day cannot determine, the map file.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "core/units.hpp"
#include "formats/iso230_tables.hpp"
#include "models/artifact/artifact.hpp"
#include "models/map/exports.hpp"
#include "models/map/map_json.hpp"
#include "models/map/volumetric.hpp"
#include "simulators/emulators/measurement_files.hpp"
#include "map_test_support.hpp"

namespace {

using namespace guideway;
using namespace guideway::map_test;

const std::string kWork = GUIDEWAY_BINARY_DIR "/map_test_work";

sm::MachineConfig second_machine() { return sm::load_machine_config(write_second_machine(kWork)); }

TEST(ErrorMapChain, TheJacobianIsTheDerivative) {
  const simulators::emulators::DayPlan plan;
  mm::ErrorMap m = sm::truth_map(second_machine(), travel_of(plan), 4);
  const std::vector<double> p0 = m.parameter_vector();
  const mm::Vec3 at{0.07, -0.12, 0.05}, tool{0.02, -0.01, -0.1};
  std::vector<double> jt(3 * m.parameters), ja(3 * m.parameters);
  mm::tool_error_jacobian(m, at, tool, jt.data());
  mm::carriage_angles_jacobian(m, 0, at, ja.data());
  const mm::Vec3 e0 = mm::tool_error(m, at, tool), a0 = mm::carriage_angles(m, 0, at);
  for (std::size_t k = 0; k < m.parameters; ++k) {
    auto p = p0;
    p[k] += 1e-6;
    m.set_parameters(p);
    const mm::Vec3 e = mm::tool_error(m, at, tool), a = mm::carriage_angles(m, 0, at);
    for (std::size_t r = 0; r < 3; ++r) {
      EXPECT_NEAR((e[r] - e0[r]) / 1e-6, jt[r * m.parameters + k], 1e-9) << "tool error row " << r << " param " << k;
      EXPECT_NEAR((a[r] - a0[r]) / 1e-6, ja[r * m.parameters + k], 1e-9) << "angles row " << r << " param " << k;
    }
  }
}

// The map's first-order chain with the machine's functions in the map's gauge is the virtual machine's exact
// chain up to a rigid body, but for the second-order terms: nothing on a machine of tens of urad, 0.9 um on the
// example machine, whose Y roll reaches 2.3 mrad (Lai's values; docs/map.md "What a map is relative to").
TEST(ErrorMapChain, IsTheVirtualMachinesUpToARigidBody) {
  const simulators::emulators::DayPlan plan;
  for (const bool example : {false, true}) {
    const sm::Machine m(example ? sm::load_machine_config(GUIDEWAY_SOURCE_DIR "/config/machine-example.toml")
                                : second_machine());
    const mm::ErrorMap truth = sm::truth_map(m.config(), travel_of(plan));
    const auto at = mm::volume_grid(truth.travel, {5, 5, 5});
    std::vector<mm::Vec3> diff;
    for (const auto& p : at) {
      const auto a = sm::static_tool_error(m, p);
      const auto b = mm::tool_error(truth, p, m.config().tool_offset);
      diff.push_back({a[0] - b[0], a[1] - b[1], a[2] - b[2]});
    }
    const double largest = mm::field_accuracy(at, diff).value_m;
    std::printf("%s: largest difference after the rigid body %.4f um\n", m.config().name.c_str(), largest * 1e6);
    EXPECT_LT(largest, example ? 1.0e-6 : 0.02e-6) << m.config().name;
  }
}

// A straightness with a slope is, in the map's gauge, a squareness: X leaning towards +y by s reads as the Y
// travel leaning towards +x by s (a rigid rotation by s takes one to the other), and the map's error field is
// the machine's up to that rotation.
TEST(ErrorMapChain, TheGaugeTurnsAStraightnessSlopeIntoSquareness) {
  sm::MachineConfig c;
  c.axis[0].translation[1].c = {0.0, 20e-6};  // E_YX = 20 urad * x
  const simulators::emulators::DayPlan plan;
  const mm::ErrorMap t = sm::truth_map(c, travel_of(plan));
  EXPECT_NEAR(t.squareness[0].value_rad, 20e-6, 1e-12);
  EXPECT_NEAR(t.squareness[1].value_rad, 0.0, 1e-12);
  EXPECT_NEAR(t.value(0, 1, 0.15), 0.0, 1e-12);  // the straightness itself is left without its line
}

TEST(Iso230Tables, ReadBackAndAgreeWithTheMap) {
  const simulators::emulators::DayPlan plan;
  const mm::ErrorMap m = sm::truth_map(second_machine(), travel_of(plan), 4);
  const auto files = mm::map_exports(m, {}, {}, "truth");
  mm::TableMap t;
  for (const auto& f : files) {
    if (f.name.rfind("iso230_", 0) != 0) continue;
    if (f.name == "iso230_squareness.csv") {
      t.squareness = formats::parse_iso230_squareness(f.content, f.name);
    } else {
      const auto a = formats::parse_iso230_axis_table(f.content, f.name);
      t.axes[static_cast<std::size_t>(a.axis - 'x')] = a;
      EXPECT_EQ(formats::iso230_columns(a.axis)[1], std::string("EX") + static_cast<char>(a.axis - 'x' + 'X'));
    }
  }
  EXPECT_NEAR(t.squareness.ec0y_urad, -m.squareness[0].value_rad * 1e6, 1e-9);
  EXPECT_NEAR(t.squareness.eb0z_urad, m.squareness[1].value_rad * 1e6, 1e-9);
  EXPECT_NEAR(t.squareness.ea0z_urad, -m.squareness[2].value_rad * 1e6, 1e-9);
  // Linear interpolation every 2 mm of functions of a few um: well below a nanometre.
  double worst = 0;
  for (const auto& p : mm::volume_grid(m.travel, {7, 7, 7})) {
    const auto a = mm::table_tool_error(t, p, m.tool_offset_m), b = mm::tool_error(m, p, m.tool_offset_m);
    for (std::size_t k = 0; k < 3; ++k) worst = std::max(worst, std::abs(a[k] - b[k]));
  }
  EXPECT_LT(worst, 1e-9);
}

TEST(Iso230Tables, RefuseWhatAControllerCouldNotLoad) {
  const auto refused = [](const std::string& text, const std::string& needle) {
    try {
      (void)formats::parse_iso230_axis_table(text, "t.csv");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const formats::Iso230TableError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  const std::string head = "# format = guideway/iso230-table/1\n# axis = y\n";
  refused(head + "Y,EXY,EYY,EZY,EAY,EBY\n0,0,0,0,0,0\n1,0,0,0,0,0\n", "t.csv:3: missing column 'ECY'");
  refused(head + "Y,EXY,EYY,EZY,EAY,EBY,ECY\n0,0,0,0,0,0,0\n0,0,0,0,0,0,0\n", "t.csv:5: position 0 does not ascend");
  refused(head + "Y,EXY,EYY,EZY,EAY,EBY,ECY\n0,0,0,0,x,0,0\n1,0,0,0,0,0,0\n", "t.csv:4");
  refused("# axis = y\nY,EXY\n", "not a table of format");
  try {
    (void)formats::parse_iso230_squareness("# format = guideway/iso230-squareness/1\nname,value_urad\nEC0X,1\n", "q.csv");
    ADD_FAILURE() << "an unknown squareness accepted";
  } catch (const formats::Iso230TableError& e) {
    EXPECT_NE(std::string(e.what()).find("q.csv:3: unknown squareness 'EC0X'"), std::string::npos) << e.what();
  }
}

// Wei's artifact along Y and Z: the same six error motions as along X, in machine directions.
TEST(ArtifactAnyAxis, RecoversTheErrorMotionsWithoutNoise) {
  sm::MachineConfig c = second_machine();
  c.noise.autocollimator_rad = 0;
  const sm::Machine m(c);
  for (const sm::Axis axis : {sm::Axis::y, sm::Axis::z}) {
    simulators::emulators::ArtifactFilesSpec s;
    s.axis = axis;
    s.spot_noise_px = 0;
    s.laser_noise_m = 0;
    s.start_m = -0.15;
    s.pitch_m = 0.0375;
    s.other = {0.03, -0.02, 0.04};
    const auto f = simulators::emulators::artifact_files(m, s);
    using namespace guideway::models::artifact;
    const auto r = identify_artifact(parse_artifact_readings(f.calibration, "c", ArtifactPlacement::calibration),
                                     parse_artifact_readings(f.horizontal, "h", ArtifactPlacement::horizontal),
                                     parse_artifact_readings(f.vertical, "v", ArtifactPlacement::vertical));
    EXPECT_EQ(r.axis, static_cast<int>(axis));
    sm::ArtifactSpec a;
    a.axis = axis;
    a.start_m = s.start_m;
    a.pitch_m = s.pitch_m;
    a.targets = s.targets;
    a.other = s.other;
    const auto t = m.artifact_measurement(a);
    for (std::size_t i = 0; i < t.size(); ++i) {
      const MachineErrors e = machine_errors(r.targets[i], static_cast<int>(axis));
      for (std::size_t k = 0; k < 3; ++k) {
        EXPECT_NEAR(e.d[k], t[i].displacement_m[k] - t[0].displacement_m[k], 1e-12) << "target " << i << " d" << k;
        EXPECT_NEAR(e.r[k], t[i].rotation_rad[k] - t[0].rotation_rad[k], 1e-12) << "target " << i << " r" << k;
      }
    }
  }
}

// The traverse of each axis: the file's slopes (the straightness session's and `guideway simulate day`'s) are
// the carriage's rotations about its pitch and yaw axes with the signs of docs/conventions.md.
TEST(TraverseAnyAxis, TheFilesAnglesAreTheCarriagesRotations) {
  sm::MachineConfig c;
  c.axis[1].rotation[0].c = {0.0, 40e-6};  // pitch of Y: about x
  c.axis[1].rotation[2].c = {0.0, -25e-6};  // yaw of Y: about z
  c.axis[2].rotation[1].c = {0.0, 30e-6};   // pitch of Z: about y
  c.axis[2].rotation[0].c = {0.0, 15e-6};   // yaw of Z: about x
  const sm::Machine m(c);
  simulators::emulators::DayPlan plan;
  plan.planes.clear();
  plan.artifact = {false, false, false};
  plan.runout = false;
  const mm::MapInputs in = simulated_day(m, plan, kWork + "/traverse");
  ASSERT_EQ(in.traverses.size(), 3u);
  for (const auto& t : in.traverses) {
    if (t.axis == 0) continue;
    for (std::size_t k = 1; k < t.position_m.size(); ++k) {
      const double du = t.position_m[k] - t.position_m[0];
      const auto& e = c.axis[static_cast<std::size_t>(t.axis)];
      const double pitch = e.rotation[static_cast<std::size_t>(mm::pitch_component(t.axis) - 3)].c[1];
      const double yaw = e.rotation[static_cast<std::size_t>(mm::yaw_component(t.axis) - 3)].c[1];
      if (t.pass[k] != t.pass[0]) continue;
      EXPECT_NEAR(t.pitch_rad[k] - t.pitch_rad[0], pitch * du, 1e-9) << "axis " << t.axis;
      EXPECT_NEAR(t.yaw_rad[k] - t.yaw_rad[0], yaw * du, 1e-9) << "axis " << t.axis;
    }
  }
}

TEST(MapDay, TheManifestIsCheckedWithItsFileNamed) {
  std::filesystem::create_directories(kWork);
  const auto refused = [](const std::string& text, const std::string& needle) {
    const std::string path = kWork + "/bad-day.json";
    FILE* f = std::fopen(path.c_str(), "w");
    std::fputs(text.c_str(), f);
    std::fclose(f);
    try {
      (void)mm::read_day(path);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  refused("{}", "not a day manifest");
  refused(R"({"format":"guideway/map-day/1","tests":[{"kind":"laser","files":["a"]}]})", "test 1: kind 'laser'");
  refused(R"({"format":"guideway/map-day/1","tests":[{"kind":"dbb","plane":"xw","files":["a"]}]})", "plane 'xw'");
  refused(R"({"format":"guideway/map-day/1","tests":[{"kind":"artifact","axis":"y","files":["a","b"]}]})",
          "an artifact is three files");
  refused(R"({"format":"guideway/map-day/1","travel_mm":{"x":[1,0]},"tests":[]})", "travel_mm.x");
}

// A day without the artifact on Y and Z: what it cannot determine is listed with the test that would, the
// squarenesses the ballbar reads together with an undetermined straightness are refused with the reason, and
// the volumetric accuracy says it is not the machine's.
TEST(MapFit, APartialDayListsWhatItCannotDetermine) {
  const sm::Machine m(sm::load_machine_config(GUIDEWAY_SOURCE_DIR "/config/machine-example.toml"));
  simulators::emulators::DayPlan plan;
  plan.artifact = {true, false, false};
  plan.traverse = {true, true, false};
  plan.runout = false;
  const mm::MapFit fit = mm::fit_map(simulated_day(m, plan, kWork + "/partial"));
  const auto& map = fit.map;
  for (int c = 0; c < 6; ++c) EXPECT_TRUE(map.function(0, c).determined) << mm::function_name(0, c);
  EXPECT_TRUE(map.function(1, 3).determined);   // pitch of Y: its traverse
  EXPECT_TRUE(map.function(1, 5).determined);   // yaw of Y
  EXPECT_FALSE(map.function(1, 4).determined);  // roll of Y
  EXPECT_NE(map.function(1, 4).why.find("electronic level"), std::string::npos) << map.function(1, 4).why;
  EXPECT_NE(map.function(1, 1).why.find("laser interferometer along Y"), std::string::npos);
  EXPECT_FALSE(map.function(2, 5).determined);  // roll of Z: no level sees a vertical axis' roll
  EXPECT_NE(map.function(2, 5).why.find("no level sees the roll of a vertical axis"), std::string::npos);
  EXPECT_FALSE(map.function(2, 4).determined);  // pitch of Z: no traverse, no artifact
  EXPECT_NE(map.function(2, 4).why.find("autocollimator traverse of Z"), std::string::npos);
  for (const auto& q : map.squareness) {
    EXPECT_FALSE(q.determined) << q.plane;
    EXPECT_NE(q.why.find("reads the squareness of the axes' lines over its circle"), std::string::npos) << q.why;
  }
  const auto va = mm::volumetric_accuracy(map, {{5, 5, 5}, {}, 10, 1});
  EXPECT_FALSE(va.missing.empty());
}

TEST(MapJson, TheMapReadsBackAsItWasWritten) {
  const simulators::emulators::DayPlan plan;
  mm::ErrorMap m = sm::truth_map(second_machine(), travel_of(plan), 3);
  m.function(2, 5).determined = false;
  m.function(2, 5).why = "no test";
  mm::assign_parameters(m);
  const auto truth = sm::truth_map(second_machine(), travel_of(plan), 3);
  std::vector<double> p(m.parameters);
  for (std::size_t k = 0; k < p.size(); ++k) p[k] = 1e-6 * static_cast<double>(k + 1);
  m.set_parameters(p);
  m.covariance.assign(m.parameters * m.parameters, 0.0);
  for (std::size_t k = 0; k < m.parameters; ++k) m.covariance[k * m.parameters + k] = 1e-14 * static_cast<double>(k + 1);
  const mm::ErrorMap back = mm::map_from_json(mm::to_json(m), "m.json");
  ASSERT_EQ(back.parameters, m.parameters);
  // Written in um and urad: the same numbers but for the last bit of the unit conversion.
  const auto a = back.parameter_vector(), b = m.parameter_vector();
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_NEAR(a[k], b[k], 1e-15 * std::abs(b[k])) << k;
  for (std::size_t k = 0; k < m.covariance.size(); ++k)
    EXPECT_NEAR(back.covariance[k], m.covariance[k], 1e-15 * std::abs(m.covariance[k])) << k;
  EXPECT_FALSE(back.function(2, 5).determined);
  EXPECT_EQ(back.function(2, 5).why, "no test");
  EXPECT_EQ(back.tool_offset_m, m.tool_offset_m);
}

}  // namespace
