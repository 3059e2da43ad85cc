// The daemon's DBB session fed with what the dbb-can driver delivers (bar length and X/Y encoder
// readings per SYNC) for Lai's three patterns traced by the virtual machine tool, with pauses between
// patterns: the session finds the circles by itself and identifies the configured errors.
#include "sessions/dbb_session.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "simulators/machine/machine.hpp"

using namespace guideway;

namespace {

class DbbChannels : public drivers::Driver {  // channel layout of dbb-can; never started
 public:
  DbbChannels() : Driver("dbb", "dbb-can", {{"bar_length", "m"}, {"x", "m"}, {"y", "m"}}, 2) {}

 protected:
  void run(std::stop_token) override {}
};

simulators::machine::MachineConfig test_machine() {
  simulators::machine::MachineConfig m;
  m.dbb.center_offset = {3e-6, -2e-6, 0};
  m.axis[0].scale = 20e-6;
  m.axis[1].scale = -10e-6;
  m.squareness.xy = 15e-6;
  m.dbb.noise_m = 0.05e-6;
  return m;
}

// Samples as the driver would publish them: t, bar, encoder x, y; `pause_s` of standing still after.
void feed_circle(sessions::Session& s, const simulators::machine::Machine& machine, double r, double h,
                 guideway::formats::DbbDirection dir, double& t0) {
  simulators::machine::DbbCircleSpec spec;
  spec.radius_m = r;
  spec.height_m = h;
  spec.direction = dir;
  spec.feed_m_per_s = 3000.0 / 60e3;
  spec.sample_rate_hz = 250.0;
  spec.t0_s = t0;
  const simulators::machine::DbbRun run = machine.dbb_circle(spec);
  std::vector<Sample> out;
  auto add = [&](double t, const simulators::machine::DbbSample& d) {
    Sample x;
    x.t_mono_ns = static_cast<std::int64_t>(t * 1e9);
    x.value_count = 3;
    x.value = {d.bar_length_m, d.encoder[0], d.encoder[1], 0, 0};
    out.push_back(x);
  };
  for (const auto& d : run.samples) add(t0 + d.t_s, d);
  const double end = t0 + run.samples.back().t_s;
  for (int i = 1; i <= 250; ++i) add(end + i / 250.0, run.samples.back());  // 1 s standing still
  t0 = end + 2.0;
  s.on_samples(out);
}

double value_of(const nlohmann::json& group, const std::string& name) {
  return group.at(name).at("value").get<double>();
}

}  // namespace

TEST(DbbSession, FindsLaisThreePatternsAndIdentifiesTheMachine) {
  const simulators::machine::Machine machine(test_machine());
  DbbChannels device;
  auto session = sessions::dbb_session_kind().create({"dbb", "", nlohmann::json::object()}, device);
  double t = 0;
  feed_circle(*session, machine, 95e-3, 31.225e-3, guideway::formats::DbbDirection::cw, t);
  EXPECT_FALSE(session->complete());
  EXPECT_NE(session->progress().find("1/3 patterns"), std::string::npos) << session->progress();
  feed_circle(*session, machine, 95e-3, 31.225e-3, guideway::formats::DbbDirection::ccw, t);
  feed_circle(*session, machine, 100e-3, 0.0, guideway::formats::DbbDirection::ccw, t);
  ASSERT_TRUE(session->complete()) << session->progress();
  const nlohmann::json p = session->identify();
  // Lai's model covers the three patterns (the fixed ball at (-3, 2) um from the circle's centre, the
  // scales); the in-plane diagnostics model none of them but the one h = 0 run, which goes one way:
  // none are fitted, a note says why, and the errors are ranked from Lai's terms.
  const auto& lai = p["lai3"];
  EXPECT_NEAR(value_of(lai, "e_x_um"), -3.0, 0.3) << lai.dump();
  EXPECT_NEAR(value_of(lai, "e_y_um"), 2.0, 0.3);
  EXPECT_NEAR((value_of(lai, "S_x") - value_of(lai, "S_y")) * 1e6, 30.0, 2.0);  // scale mismatch 20 - (-10) ppm
  EXPECT_FALSE(p["diagnostics"].contains("squareness_urad"));
  ASSERT_FALSE(p["notes"].empty());
  EXPECT_NE(p["notes"][0].get<std::string>().find("no ballbar diagnostics"), std::string::npos);
  EXPECT_EQ(p["ranking_model"], "lai3");
  EXPECT_FALSE(p["ranking"].empty());
  EXPECT_EQ(p["runs"].size(), 3u);
}

TEST(DbbSession, ACircleMatchingNoPatternIsReportedNotUsed) {
  const simulators::machine::Machine machine(test_machine());
  DbbChannels device;
  auto session = sessions::dbb_session_kind().create({"dbb", "", nlohmann::json::object()}, device);
  double t = 0;
  feed_circle(*session, machine, 150e-3, 0.0, guideway::formats::DbbDirection::ccw, t);
  EXPECT_NE(session->progress().find("matches no pattern"), std::string::npos) << session->progress();
  EXPECT_THROW(session->identify(), std::runtime_error);
}

TEST(DbbSession, StopAfterOnePatternIdentifiesWhatWasTraced) {
  const simulators::machine::Machine machine(test_machine());
  DbbChannels device;
  nlohmann::json opts = {{"patterns", {{{"radius_mm", 100}, {"height_mm", 0}, {"direction", "ccw"}},
                                       {{"radius_mm", 100}, {"height_mm", 0}, {"direction", "cw"}}}}};
  auto session = sessions::dbb_session_kind().create({"dbb", "", opts}, device);
  double t = 0;
  feed_circle(*session, machine, 100e-3, 0.0, guideway::formats::DbbDirection::ccw, t);
  EXPECT_FALSE(session->complete());
  const nlohmann::json p = session->identify();
  EXPECT_EQ(p["incomplete"], "1 of 2 patterns traced");
  EXPECT_NEAR(value_of(p["diagnostics"], "center_offset_x_um"), 3.0, 0.3);  // one run: no run prefix
}

TEST(DbbSession, BadOptionsAreRefusedWithTheirName) {
  DbbChannels device;
  auto kind = sessions::dbb_session_kind();
  EXPECT_THROW(kind.create({"dbb", "", {{"radius_mm", 100}}}, device), std::invalid_argument);
  try {
    kind.create({"dbb", "", {{"patterns", {{{"radius_mm", -5}}}}}}, device);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("radius_mm"), std::string::npos) << e.what();
  }
}
