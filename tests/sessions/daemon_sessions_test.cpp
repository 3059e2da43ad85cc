// The daemon's straightness, runout and profile sessions fed with what their drivers deliver (the
// autocollimator's angle pairs with no-reflection gaps between stations, the micrometer's
// displacements, the profilometer's points with start/end flags), the data coming from the virtual
// machine tool: each session finds its measurement in the stream by itself, identifies the machine's
// configured errors, and its derived file identifies offline to the very same result.
#include <gtest/gtest.h>

#include <set>

#include <cmath>
#include <numbers>

#include "drivers/profilometer/profile_stream.hpp"
#include "models/explain/explanation.hpp"
#include "models/explain/traverse_explain.hpp"
#include "models/flatness/json.hpp"
#include "models/flatness/runout.hpp"
#include "models/flatness/straightness.hpp"
#include "sessions/profile_session.hpp"
#include "sessions/runout_session.hpp"
#include "sessions/straightness_session.hpp"
#include "simulators/machine/machine.hpp"
#include "test_support.hpp"

using namespace guideway;

namespace {

class Channels : public drivers::Driver {  // a driver's channel layout; never started
 public:
  Channels(std::string driver, std::vector<drivers::ChannelInfo> ch)
      : Driver("dev", std::move(driver), std::move(ch), 2) {}

 protected:
  void run(std::stop_token) override {}
};

Channels autocollimator_device() { return Channels("autocollimator-serial", {{"angle_x", "rad"}, {"angle_y", "rad"}}); }
Channels micrometer_device() { return Channels("micrometer-modbus", {{"displacement", "m"}}); }
Channels profilometer_device() {
  return Channels("profilometer-tcp", {{"x", "m"}, {"z", "m"}, {"profile", "1"}, {"index", "1"}});
}

Sample sample(double t_s, std::initializer_list<double> values, std::uint32_t flags = 0) {
  Sample s;
  s.t_mono_ns = static_cast<std::int64_t>(std::llround(t_s * 1e9));
  s.flags = flags;
  s.value_count = static_cast<std::uint32_t>(values.size());
  std::size_t i = 0;
  for (double v : values) s.value[i++] = v;
  return s;
}

// The autocollimator polled every 50 ms: `dwell_s` on each station, the beam lost for `move_s` between
// stations and `return_s` after the last (as guideway-emulate autocollimator does).
void feed_traverse(sessions::Session& s, const std::vector<simulators::machine::TraverseStation>& st, double& t,
                   double dwell_s = 0.8, double move_s = 0.5, double return_s = 1.5, std::size_t first = 0,
                   double hole_at_s = -1) {
  std::vector<Sample> out;
  const double nan = std::nan("");
  const double t_begin = t;
  for (std::size_t k = first; k < st.size(); ++k) {
    for (double e = 0; e < dwell_s; e += 0.05, t += 0.05) {
      // A link outage of 0.6 s (two reply timeouts) at hole_at_s: no samples at all.
      if (hole_at_s >= 0 && t - t_begin >= hole_at_s && t - t_begin < hole_at_s + 0.6) continue;
      out.push_back(sample(t, {st[k].yaw_rad, st[k].pitch_rad}));
    }
    const double gap = k + 1 == st.size() ? return_s : move_s;
    for (double e = 0; e < gap; e += 0.05, t += 0.05) out.push_back(sample(t, {nan, nan}, sample_no_signal));
  }
  s.on_samples(out);
}

simulators::machine::MachineConfig straightness_machine() {
  simulators::machine::MachineConfig m;
  m.axis[0].rotation[1].c = {0.0, 30e-6, -80e-6};  // E_BX: pitch of X, rad (u in m)
  m.axis[0].rotation[2].c = {5e-6, -20e-6};        // E_CX: yaw of X
  return m;
}

std::vector<simulators::machine::TraverseStation> traverse(const simulators::machine::Machine& machine) {
  simulators::machine::TraverseSpec spec;
  spec.start_m = 0.0;
  spec.end_m = 0.6;
  spec.step_m = 0.05;
  return machine.autocollimator_traverse(spec);
}

// The single forward pass at 50 mm of the traverses above.
nlohmann::json one_pass() { return {{"passes", 1}, {"step_mm", 50}}; }

double value(const nlohmann::json& group, const char* name) { return group.at(name).at("value").get<double>(); }

}  // namespace

TEST(StraightnessSession, WaitsForTheReturnThenIdentifiesTheTraverse) {
  const simulators::machine::Machine machine(straightness_machine());
  const auto st = traverse(machine);
  ASSERT_EQ(st.size(), 13u);
  auto device = autocollimator_device();
  auto session = sessions::straightness_session_kind().create({"straightness", "", one_pass()}, device);
  double t = 100.0;
  feed_traverse(*session, st, t, 0.8, 0.5, 1.5, 7);  // started in the middle of a traverse: ignored
  EXPECT_FALSE(session->complete());
  feed_traverse(*session, st, t);
  ASSERT_TRUE(session->complete()) << session->progress();
  const nlohmann::json p = results::to_json(session->identify());

  // Reference: the model on the machine's own angles (slope = -rotation about +y; yaw = +rotation about z).
  models::flatness::AngleTraverse tr;
  tr.step_m = 0.05;
  for (const auto& s : st) {
    tr.x_m.push_back(s.position_m);
    tr.pitch_rad.push_back(-s.pitch_rad);
    tr.yaw_rad.push_back(s.yaw_rad);
    tr.line.push_back(0);
  }
  const auto ref = models::flatness::identify_straightness(tr);
  EXPECT_EQ(p["traverse"]["stations"], 13);
  EXPECT_FALSE(p.contains("incomplete"));
  const auto& g = p["straightness"];
  EXPECT_NEAR(value(g, "vertical_least_squares_um"), ref.vertical.least_squares.straightness_m * 1e6, 1e-6);
  EXPECT_NEAR(value(g, "horizontal_minimum_zone_um"), ref.horizontal->minimum_zone.straightness_m * 1e6, 1e-6);
  // The machine's truth: heights are the integral of -E_BX (a quadratic plus a cubic): clearly not straight.
  EXPECT_GT(value(g, "vertical_least_squares_um"), 1.0);
  EXPECT_GT(g["vertical_least_squares_um"]["u"].get<double>(), 0.0);

  // The derived file, identified offline, gives the same numbers.
  test::TempDir dir;
  const auto files = session->write_derived(dir.path().string(), "s");
  ASSERT_EQ(files.size(), 1u);
  nlohmann::json offline = models::flatness::to_json(
      models::flatness::identify_straightness(models::flatness::read_angle_traverse(files[0])));
  offline.erase("source");
  EXPECT_EQ(offline, p["result"]);
}

TEST(StraightnessSession, AnOutageOfTheLinkDropsTheTraverseAndTheNextIsTaken) {
  const simulators::machine::Machine machine(straightness_machine());
  const auto st = traverse(machine);
  auto device = autocollimator_device();
  auto session = sessions::straightness_session_kind().create({"straightness", "", one_pass()}, device);
  double t = 0;
  feed_traverse(*session, st, t, 0.8, 0.5, 1.5, 10);
  feed_traverse(*session, st, t, 0.8, 0.5, 1.5, 0, 5.3);  // no readings for 0.6 s on the 5th station
  EXPECT_FALSE(session->complete());
  EXPECT_NE(session->progress().find("waiting for the next traverse"), std::string::npos) << session->progress();
  feed_traverse(*session, st, t);
  ASSERT_TRUE(session->complete()) << session->progress();
  EXPECT_EQ(results::to_json(session->identify())["traverse"]["stations"], 13);
}

TEST(StraightnessSession, EqualAnglesOnConsecutiveStationsAreStillSeparateStations) {
  const simulators::machine::Machine perfect{
      simulators::machine::MachineConfig{}};  // every station reads the same angles
  const auto st = traverse(perfect);
  auto device = autocollimator_device();
  auto session = sessions::straightness_session_kind().create(
      {"straightness", "", {{"start", "now"}, {"stations", 5}, {"step_mm", 50}, {"passes", 1}}}, device);
  EXPECT_FALSE(session->time_left_s());  // no pace yet
  double t = 0;
  feed_traverse(*session, {st.begin(), st.begin() + 3}, t, 0.8, 0.5, 0.5);
  // The time left: 2 stations at the pace of the first 3 (0.8 s on each, 0.5 s between).
  ASSERT_TRUE(session->time_left_s()) << session->progress();
  EXPECT_NEAR(*session->time_left_s(), 2 * 1.3, 0.15);
  feed_traverse(*session, st, t, 0.8, 0.5, 1.5, 3);
  ASSERT_TRUE(session->complete());
  const auto p = results::to_json(session->identify());
  EXPECT_EQ(p["traverse"]["stations"], 5);
  EXPECT_NEAR(value(p["straightness"], "vertical_end_point_um"), 0.0, 1e-9);
}

TEST(StraightnessSession, ReadingsThatJumpWithoutABeamBreakStartANewStation) {
  auto device = autocollimator_device();
  auto session = sessions::straightness_session_kind().create(
      {"straightness", "", {{"start", "now"}, {"step_mm", 50}, {"passes", 1}}}, device);
  std::vector<Sample> out;
  const double a = models::flatness::rad_per_arcsec;
  double t = 0;
  for (double pitch : {1.0, 3.0, 2.0}) {  // slid from station to station with the beam on
    for (int i = 0; i < 10; ++i, t += 0.05) out.push_back(sample(t, {0.0, pitch * a}));
  }
  session->on_samples(out);
  const auto p = results::to_json(session->identify());  // stopped: the stations so far
  EXPECT_EQ(p["traverse"]["stations"], 3);
  EXPECT_EQ(p["incomplete"], "stopped after 3 stations");
  const auto& stations = p["result"]["vertical"]["stations"];
  // Heights: 0, -1", -4" (the sign: a positive rotation about +y is a falling surface) times 50 mm.
  EXPECT_NEAR(stations[2]["height_um"].get<double>(), -4.0 * a * 0.05 * 1e6, 1e-9);
}

// The session at its defaults (forward and back, 18.75 mm) on the example machine as guideway-emulate
// autocollimator runs it at its defaults (station k read at machine time k x 2 s, its noise the file's seed):
// its EXPLAIN names the machine file's autocollimator errors, the reflector's rocking (0.2") and the drift
// (0.1"/min), and nothing else. At 1.3 s a station (0.8 s dwells) the drift of 0.1"/min is 0.07" between
// the two readings at an end of the axis, against 0.05" of noise a reading: found with 5 of 21 noise seeds.
TEST(StraightnessSession, ForwardAndReturnExplainTheExampleMachinesRockingAndDrift) {
  const simulators::machine::Machine machine(
      simulators::machine::load_machine_config(GUIDEWAY_SOURCE_DIR "/config/machine-example.toml"));
  simulators::machine::TraverseSpec spec;
  spec.end_m = 0.6;
  spec.step_m = 0.01875;
  const double dwell_s = 1.5, move_s = 0.5;  // the emulator's defaults
  spec.dwell_s = dwell_s + move_s;
  std::vector<simulators::machine::TraverseStation> st;
  for (const auto& pass : machine.autocollimator_passes(spec, 2, spec.dwell_s))
    st.insert(st.end(), pass.begin(), pass.end());
  ASSERT_EQ(st.size(), 66u);
  auto device = autocollimator_device();
  auto session = sessions::straightness_session_kind().create({"straightness", "", {{"start", "now"}}}, device);
  double t = 0;
  feed_traverse(*session, st, t, dwell_s, move_s);
  ASSERT_TRUE(session->complete()) << session->progress();
  const auto p = results::to_json(session->identify());
  EXPECT_EQ(p["traverse"]["stations"], 33);  // the first pass
  EXPECT_EQ(p["traverse"]["passes"], 2);

  const auto e = session->explain();
  ASSERT_TRUE(e);
  std::map<std::string, std::map<std::string, results::ExplainEstimate>> found;
  for (const auto& f : e->findings) found[f.effect] = f.parameters;
  ASSERT_EQ(found.size(), 2u) << results::to_json(*e).dump(1);
  for (const auto& [effect, name, truth] : {std::tuple{"reflector_rocking", "reflector_rocking_arcsec", 0.2},
                                            std::tuple{"angle_drift", "angle_drift_arcsec_per_min", 0.1}}) {
    ASSERT_TRUE(found.count(effect)) << results::to_json(*e).dump(1);
    const auto& v = found[effect].at(name);
    EXPECT_LT(std::abs(v.value - truth), 4 * v.u) << v.value << " +/- " << v.u;
    std::cerr << effect << ": " << v.value << " +/- " << v.u << ", the file's " << truth << "\n";
  }
  EXPECT_FALSE(e->unexplained);

  // The derived file has each reading's time and pass: explained offline, the same findings.
  test::TempDir dir;
  const auto files = session->write_derived(dir.path().string(), "s");
  ASSERT_EQ(files.size(), 1u);
  const results::Explanation offline = models::explain::explanation_of(
      models::explain::explain_traverses(models::explain::read_traverse_passes(files[0])));
  ASSERT_EQ(offline.findings.size(), e->findings.size());
  for (std::size_t i = 0; i < offline.findings.size(); ++i)  // every u of a traverse's effects is finite
    EXPECT_EQ(offline.findings[i].parameters, e->findings[i].parameters);
}

TEST(StraightnessSession, TooFewStationsFailWithTheReason) {
  auto device = autocollimator_device();
  auto session = sessions::straightness_session_kind().create({"straightness", "", nlohmann::json::object()}, device);
  try {
    session->identify();
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no return of the reflector"), std::string::npos) << e.what();
  }
}

TEST(RunoutSession, OneRevolutionGivesTheRunoutAndTheSquareness) {
  simulators::machine::MachineConfig cfg;
  cfg.spindle.tilt_x_rad = 5.0e-6;
  cfg.spindle.plate_parallelism_rad = 2.5e-6;  // p = 2.5 urad * 100 mm = 0.25 um
  cfg.noise.micrometer_m = 0.01e-6;
  const simulators::machine::Machine machine(cfg);
  simulators::machine::RunoutSpec spec;
  spec.probe_radius_m = 0.05;
  spec.samples_per_rev = 300;  // 50 Hz at 10 rpm
  spec.revolutions = 2;
  const auto rev = machine.runout_revolution(spec);
  auto device = micrometer_device();
  auto session = sessions::runout_session_kind().create({"runout",
                                                         "",
                                                         {{"plate_diameter_mm", 100},
                                                          {"parallelism_um", 0.25},
                                                          {"rpm", 10},
                                                          {"revolutions", 1},
                                                          {"artifact_turned_deg", 180}}},
                                                        device);
  std::vector<Sample> out;
  for (const auto& r : rev) out.push_back(sample(50.0 + r.t_s, {r.displacement_m}));
  ASSERT_TRUE(session->time_left_s());
  EXPECT_DOUBLE_EQ(*session->time_left_s(), 6.0);  // one turn at 10 rpm
  session->on_samples(std::span(out).first(150));
  EXPECT_NEAR(*session->time_left_s(), 3.0, 0.03);  // half of it turned
  EXPECT_FALSE(session->complete());
  EXPECT_NE(session->progress().find("of 360 deg"), std::string::npos) << session->progress();
  session->on_samples(std::span(out).subspan(150));
  ASSERT_TRUE(session->complete());
  const auto p = results::to_json(session->identify());
  EXPECT_EQ(p["revolution"]["samples"], 301);  // one turn and the reading that closes it: no more of the second
  // Truth: the spindle's lean relative to the plate across the 100 mm plate, peak to peak; Eq. 21
  // adds p back and gives the lean itself.
  const double r_um = 100e-3 * (5.0e-6 - 2.5e-6) * 1e6;
  const auto& g = p["squareness"];
  EXPECT_NEAR(value(g, "runout_um"), r_um, 0.01);
  EXPECT_NEAR(value(g, "squareness_urad"), (value(g, "runout_um") + 0.25) / 100.0 * 1e3, 1e-9);  // Eq. 21
  EXPECT_NEAR(value(g, "squareness_urad"), 5.0, 0.1);
  EXPECT_NEAR(value(g, "squareness_amplitude_um"), value(g, "squareness_urad") * 600e-3, 1e-9);  // travel 600 mm
  EXPECT_LT(g["runout_um"]["u"].get<double>(), 0.01);

  test::TempDir dir;
  const auto files = session->write_derived(dir.path().string(), "r");
  ASSERT_EQ(files.size(), 1u);
  const auto written = models::flatness::read_runout_revolution(files[0]);
  EXPECT_EQ(models::flatness::runout_json(written), p["result"]);
  // The record states the artifact's turn, and that its angles start at its first reading (no spindle index).
  ASSERT_TRUE(written.artifact_turned_rad);
  EXPECT_DOUBLE_EQ(*written.artifact_turned_rad, std::numbers::pi);
  EXPECT_FALSE(written.angle_from_spindle_zero);
  EXPECT_EQ(session->metadata().at("artifact_turned_deg"), "180");
  // One revolution: its error motion has no asynchronous part, and there is nothing to explain it from.
  EXPECT_EQ(p["revolution"]["revolutions"], 1);
  const auto e = session->explain();
  ASSERT_TRUE(e);
  EXPECT_NE(e->not_analysed.find("fewer than 2 whole revolutions"), std::string::npos) << e->not_analysed;
}

// The defaults: 20 revolutions at 60 rpm of the example machine's spindle, read at 50 Hz: the ISO 230-7
// values and an EXPLAIN that names the spindle's errors (the machine file's) and nothing else.
TEST(RunoutSession, TwentyRevolutionsGiveTheErrorMotionAndTheirExplanation) {
  const simulators::machine::Machine machine(simulators::machine::default_machine_config());
  simulators::machine::RunoutSpec spec;
  spec.rpm = 60;
  spec.samples_per_rev = 50;
  spec.revolutions = 21;
  auto device = micrometer_device();
  auto session = sessions::runout_session_kind().create({"runout", "", nlohmann::json::object()}, device);
  std::vector<Sample> out;
  for (const auto& r : machine.runout_revolution(spec)) out.push_back(sample(50.0 + r.t_s, {r.displacement_m}));
  session->on_samples(out);
  ASSERT_TRUE(session->complete());
  const auto p = results::to_json(session->identify());
  EXPECT_EQ(p["revolution"]["revolutions"], 20);
  EXPECT_EQ(p["revolution"]["samples"], 1001);  // 20 turns and the reading that closes the last
  const auto& em = p["error_motion"];
  // Synchronous: the 2nd and 3rd harmonics (0.05, 0.12 um); asynchronous: the 3.7 line (0.08 um, up to
  // 0.16 um wide) and 20 s of growth at 0.3 um/min (0.1 um), with 0.01 um of noise.
  const double sync = value(em, "synchronous_error_motion_um"), async = value(em, "asynchronous_error_motion_um");
  EXPECT_GT(sync, 0.25);
  EXPECT_LT(sync, 0.40);
  EXPECT_GT(async, 0.15);
  EXPECT_LT(async, 0.35);
  EXPECT_GE(value(em, "total_error_motion_um"), std::max(sync, async));
  const auto e = session->explain();
  ASSERT_TRUE(e);
  std::multiset<std::string> effects;
  for (const auto& f : e->findings) effects.insert(f.effect);
  EXPECT_EQ(effects, (std::multiset<std::string>{"asynchronous_line", "synchronous_harmonic", "synchronous_harmonic",
                                                 "thermal_drift"}))
      << results::to_json(*e).dump();
  EXPECT_FALSE(e->unexplained) << results::to_json(*e).dump();
}

TEST(ProfileSession, TakesOneWholeProfileAndFindsTheFeedMarks) {
  simulators::machine::MachineConfig cfg;
  cfg.noise.profilometer_m = 0.02e-6;
  const simulators::machine::Machine machine(cfg);
  simulators::machine::FacingSpec spec;
  spec.x_start_m = 0.050;
  spec.x_end_m = 0.060;
  spec.feed_m_per_s = 2.0 / 60000.0;  // 20 um per revolution at 100 rpm
  spec.spindle_rpm = 100.0;
  spec.profile_step_m = 1e-6;
  const auto points = machine.facing_profile(spec);
  auto device = profilometer_device();
  auto session = sessions::profile_session_kind().create({"profile", "", nlohmann::json::object()}, device);
  std::vector<Sample> out;
  double t = 0;
  auto emit = [&](double id, std::size_t from) {
    for (std::size_t i = from; i < points.size(); ++i, t += 2e-4) {
      std::uint32_t f = i == 0 ? drivers::profilometer::sample_profile_start : 0;
      if (i + 1 == points.size()) f |= drivers::profilometer::sample_profile_end;
      out.push_back(sample(t, {points[i].x_m, points[i].z_m, id, static_cast<double>(i)}, f));
    }
  };
  emit(1, 9000);  // the end of a profile already under way: not taken
  session->on_samples(out);
  EXPECT_FALSE(session->complete());
  out.clear();
  emit(2, 0);
  emit(3, 0);
  session->on_samples(out);
  ASSERT_TRUE(session->complete());
  const auto p = results::to_json(session->identify());
  EXPECT_EQ(p["profile_id"], 2);
  EXPECT_EQ(p["points"]["count"], points.size());
  // 20 um feed marks at 1 um spacing: periods of 16-32 points are Haar band d4.
  const std::string dominant = p["wavelet"]["dominant_detail"];
  EXPECT_EQ(dominant, "d4") << p["wavelet"].dump();
  // The noise estimate from the finest details finds the configured 0.02 um (the feed marks' slope adds a bit).
  EXPECT_NEAR(value(p["profile"], "noise_um"), 0.02, 0.01);
  // Mark depth f^2 / (8 R) = 62.5 nm plus noise: the profile's straightness is of that order; the
  // form (approximation) has neither marks nor noise.
  EXPECT_GT(value(p["profile"], "straightness_lsq_um"), 0.06);
  EXPECT_LT(value(p["profile"], "straightness_lsq_um"), 0.3);
  EXPECT_LT(value(p["profile"], "form_straightness_um"), value(p["profile"], "straightness_lsq_um"));

  test::TempDir dir;
  const auto files = session->write_derived(dir.path().string(), "p");
  ASSERT_EQ(files.size(), 1u);
  nlohmann::json offline = results::to_json(sessions::evaluate_profile(formats::read_profile_csv(files[0])));
  offline["profile_id"] = p["profile_id"];
  EXPECT_EQ(offline, p);
}

TEST(ProfileSession, StoppedBeforeTheEndFailsWithTheReason) {
  auto device = profilometer_device();
  auto session = sessions::profile_session_kind().create({"profile", "", nlohmann::json::object()}, device);
  std::vector<Sample> out{sample(0, {0.0, 0.0, 7, 0}, drivers::profilometer::sample_profile_start),
                          sample(1e-3, {1e-6, 0.0, 7, 1})};
  session->on_samples(out);
  EXPECT_FALSE(session->complete());
  EXPECT_THROW(session->identify(), std::runtime_error);
}

TEST(SessionOptions, BadOptionsAreRefusedWithTheirName) {
  auto ac = autocollimator_device();
  auto mm = micrometer_device();
  auto pf = profilometer_device();
  auto expect_refused = [](const std::function<void()>& f, const std::string& name) {
    try {
      f();
      ADD_FAILURE() << name << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  const auto s = sessions::straightness_session_kind();
  const auto r = sessions::runout_session_kind();
  const auto p = sessions::profile_session_kind();
  expect_refused([&] { s.create({"straightness", "", {{"step_mm", -1}}}, ac); }, "step_mm");
  expect_refused([&] { s.create({"straightness", "", {{"stations", 2.5}}}, ac); }, "stations");
  expect_refused([&] { s.create({"straightness", "", {{"start", "later"}}}, ac); }, "start");
  expect_refused([&] { s.create({"straightness", "", {{"pitch_channel", "nope"}}}, ac); }, "nope");
  expect_refused([&] { s.create({"straightness", "", {{"stepmm", 1}}}, ac); }, "stepmm");
  // Issue 46 item 12: one channel read for both angles.
  expect_refused([&] { s.create({"straightness", "", {{"pitch_channel", "angle_y"}, {"yaw_channel", "angle_y"}}}, ac); },
                 "pitch_channel and yaw_channel name the same channel \"angle_y\"");
  expect_refused([&] { r.create({"runout", "", {{"plate_diameter_mm", "big"}}}, mm); }, "plate_diameter_mm");
  expect_refused([&] { r.create({"runout", "", {{"rpm", 0}}}, mm); }, "rpm");
  expect_refused([&] { p.create({"profile", "", {{"wavelet", "db99"}}}, pf); }, "wavelet");
  expect_refused([&] { p.create({"profile", "", {{"level", 0}}}, pf); }, "level");
}
