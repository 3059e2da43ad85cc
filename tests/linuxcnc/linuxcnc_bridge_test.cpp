// The LinuxCNC bridge's pieces without LinuxCNC: the stream's reader (periods, lost periods announced or
// not, the s32 counter's wrap, bad lines), the bridge itself on a stand-in for halsampler (its overrun
// lines, a client joining late), the follower's playback (steady delay, interpolation, underruns), the
// machine stepped by servo periods against simulate_motion, and the test program's G-code.
#include <gtest/gtest.h>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <regex>
#include <sstream>
#include <thread>

#include "drivers/linuxcnc/bridge.hpp"
#include "drivers/linuxcnc/hal_stream.hpp"
#include "formats/dbb_program.hpp"
#include "simulators/emulators/linuxcnc_follower.hpp"
#include "simulators/machine/machine.hpp"

namespace {

using namespace guideway::drivers::linuxcnc;
namespace machine = guideway::simulators::machine;
namespace emulators = guideway::simulators::emulators;
namespace formats = guideway::formats;

constexpr double pi = std::numbers::pi;

std::string header(const std::vector<std::string>& columns) {
  HalStreamHeader h;
  h.period_ns = 1000000;
  h.columns = columns;
  return format_hal_stream_header(h);
}

struct Collected {
  std::vector<std::int64_t> seq;
  std::vector<std::vector<double>> values;
  std::vector<std::pair<std::uint64_t, std::string>> lost;
};

HalStreamReader collecting(Collected& c) {
  return HalStreamReader(
      [&c](std::int64_t seq, std::span<const double> v) {
        c.seq.push_back(seq);
        c.values.emplace_back(v.begin(), v.end());
      },
      [&c](std::uint64_t n, std::string_view why) { c.lost.emplace_back(n, std::string(why)); });
}

TEST(HalStream, ReadsTheHeaderAndThePeriodsInPieces) {
  Collected c;
  auto r = collecting(c);
  const std::string text = header({"a", "b"}) + "7 1.5 -2 \n8 1.25 0\n";
  for (char ch : text) r.feed(std::string_view(&ch, 1));  // byte by byte, as a socket may deliver
  ASSERT_TRUE(r.error().empty()) << r.error();
  EXPECT_EQ(r.header().period_ns, 1000000);
  EXPECT_EQ(r.header().column("b"), 1);
  EXPECT_EQ(r.header().column("c"), -1);
  ASSERT_EQ(c.seq, (std::vector<std::int64_t>{7, 8}));
  EXPECT_EQ(c.values[0], (std::vector<double>{1.5, -2.0}));
  EXPECT_EQ(r.counters().periods, 2u);
  EXPECT_EQ(r.counters().lost, 0u);
}

TEST(HalStream, CountsEveryLostPeriodAnnouncedOrNot) {
  Collected c;
  auto r = collecting(c);
  // 3 announced and skipped (10 -> 14), then 2 skipped without a word (14 -> 17).
  r.feed(header({"a"}) + "10 0\n! lost 3 halsampler overrun\n14 0\n17 0\n");
  EXPECT_EQ(r.counters().lost, 5u);
  EXPECT_EQ(r.counters().lost_unannounced, 2u);
  ASSERT_EQ(c.lost.size(), 2u);
  EXPECT_EQ(c.lost[0].second, "halsampler overrun");
  EXPECT_EQ(c.lost[1].second, "sample numbers skipped");
}

TEST(HalStream, TheSampleNumberWrapsAroundAsAnS32) {
  Collected c;
  auto r = collecting(c);
  r.feed(header({"a"}) + "2147483647 0\n-2147483648 0\n-2147483646 0\n");
  EXPECT_EQ(seq_step(2147483647, -2147483648LL), 1);
  EXPECT_EQ(r.counters().periods, 3u);
  EXPECT_EQ(r.counters().lost, 1u);  // -2147483647 is missing
}

TEST(HalStream, BadLinesAreCountedAndSkipped) {
  Collected c;
  auto r = collecting(c);
  r.feed(header({"a", "b"}) + "1 0 0\n2 0\n3 0 x\n3 0 0 0\nnonsense\n4 0 nan\n4 1 1\n4 2 2\n! what\n5 3 3\n");
  EXPECT_EQ(c.seq, (std::vector<std::int64_t>{1, 4, 5}));
  EXPECT_EQ(r.counters().bad_lines, 7u);
  EXPECT_EQ(r.counters().lost, 2u);  // 2 and 3 never came as periods
}

TEST(HalStream, RefusesAStreamThatIsNotTheBridgesAndLongLines) {
  Collected c;
  auto r = collecting(c);
  r.feed("1 2 3\n");
  EXPECT_NE(r.error().find("not a guideway-linuxcnc-bridge stream"), std::string::npos);
  Collected d;
  auto r2 = collecting(d);
  r2.feed(std::string(hal_stream_magic) + "\n# columns = a,a\n# end\n");
  EXPECT_NE(r2.error().find("named twice"), std::string::npos) << r2.error();
  Collected e;
  auto r3 = collecting(e);
  r3.feed(header({"a"}) + std::string(70000, '1'));
  EXPECT_NE(r3.error().find("64 KiB"), std::string::npos);
  EXPECT_THROW(parse_column_list("a,,b"), std::invalid_argument);
  EXPECT_EQ(parse_column_list(std::string(default_columns)).size(), default_sampler_cfg.size());
}

// A client of the bridge's socket: everything it says until it closes.
std::string read_all(const std::string& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof(addr.sun_path), "%s", path.c_str());
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  for (int i = 0; i < 200 && ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0; ++i)
    ::usleep(10000);
  std::string out;
  char buf[4096];
  ssize_t n;
  while ((n = ::read(fd, buf, sizeof(buf))) > 0) out.append(buf, static_cast<std::size_t>(n));
  ::close(fd);
  return out;
}

TEST(Bridge, ServesTheSourcesPeriodsAndSaysWhatTheOverrunLost) {
  const auto dir = std::filesystem::temp_directory_path() / ("guideway-bridge-test-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string sock = (dir / "bridge.sock").string();
  const std::string go = (dir / "go").string();
  // halsampler's form: a period, an overrun mark, the next number 4 on, a line that is no period; the
  // source waits until the client is there (the file "go"), then ends.
  BridgeOptions o;
  o.socket_path = sock;
  o.columns = {"x", "on"};
  o.source_command = {"/bin/sh", "-c",
                      "while [ ! -e " + go + " ]; do sleep 0.01; done; printf '1 0.5 0 \\n2 0.6 1 \\noverrun\\n6 0.7 "
                      "1 \\nbroken\\n7 0.8 0 \\n'"};
  std::ostringstream log;
  BridgeCounters counters;
  std::thread bridge([&] { run_bridge(o, log, &counters); });
  std::string got;
  std::thread client([&] { got = read_all(sock); });
  while (!std::filesystem::exists(sock)) ::usleep(5000);
  ::usleep(100000);
  std::ofstream(go).put('\n');
  client.join();
  bridge.join();
  EXPECT_EQ(counters.periods, 4u);
  EXPECT_EQ(counters.lost_overrun, 3u);
  EXPECT_EQ(counters.bad_lines, 1u);
  EXPECT_EQ(counters.clients, 1u);
  EXPECT_NE(log.str().find("4 periods, 3 lost to halsampler overruns"), std::string::npos) << log.str();
  Collected c;
  auto r = collecting(c);
  r.feed(got);
  EXPECT_TRUE(r.error().empty()) << r.error() << "\n" << got;
  EXPECT_EQ(c.seq, (std::vector<std::int64_t>{1, 2, 6, 7}));
  EXPECT_EQ(r.counters().lost, 3u);
  EXPECT_EQ(r.counters().lost_unannounced, 0u);
  ASSERT_EQ(c.lost.size(), 1u);
  EXPECT_EQ(c.lost[0].second, "halsampler overrun");
  EXPECT_FALSE(std::filesystem::exists(sock));  // removed at the end
  std::filesystem::remove_all(dir);
}

TEST(FollowPlayback, PlaysBackASteadyDelayBehindAndCountsAStall) {
  emulators::FollowPlayback p(0.05);
  std::array<double, 4> out{};
  EXPECT_FALSE(p.at(0.0, out));
  // 1 kHz periods arriving in bursts of 10 every 10 ms, the burst's last one at its arrival.
  const auto burst = [&](double wall, double clock = 1.0) {
    std::vector<emulators::FollowFrame> f(10);
    for (int i = 0; i < 10; ++i) {
      auto& fr = f[static_cast<std::size_t>(i)];
      fr.t_s = (wall - 0.009 + i * 0.001) * clock;
      fr.bus_m = {fr.t_s, 0, 0, 0};
    }
    p.arrived(wall, f.data(), f.size());
  };
  for (int k = 1; k <= 100; ++k) burst(k * 0.01);
  EXPECT_NEAR(p.delay_s(), 0.05, 1e-12);
  ASSERT_TRUE(p.at(1.0, out));
  EXPECT_NEAR(out[0], 1.0 - 0.05, 1e-9);  // interpolated, the delay behind
  ASSERT_TRUE(p.at(1.0043, out));
  EXPECT_NEAR(out[0], 1.0043 - 0.05, 1e-9);
  // The link stalls for 0.4 s: the player holds the newest period and counts one underrun; the periods
  // of the stall then come at once, and the delay grows to absorb such a stall.
  EXPECT_TRUE(p.at(1.2, out));
  EXPECT_TRUE(p.at(1.3, out));
  EXPECT_EQ(p.underruns(), 1u);
  EXPECT_NEAR(out[0], 1.0, 1e-9);
  std::vector<emulators::FollowFrame> late(400);
  for (std::size_t i = 0; i < late.size(); ++i) {
    late[i].t_s = 1.001 + 0.001 * static_cast<double>(i);
    late[i].bus_m = {late[i].t_s, 0, 0, 0};
  }
  p.arrived(1.4, late.data(), late.size());
  EXPECT_NEAR(p.delay_s(), 1.5 * 0.4, 1e-9);
  ASSERT_TRUE(p.at(1.41, out));
  EXPECT_GE(out[0], 1.0);  // never back in time
  EXPECT_LT(out[0], 1.0 + 0.11);  // on from where it held, a little slower (the buffer is shallow)
  // The stream ends: the last period holds, no underrun.
  p.end_of_stream();
  EXPECT_TRUE(p.at(5.0, out));
  EXPECT_NEAR(out[0], 1.4, 1e-9);
  EXPECT_EQ(p.underruns(), 1u);
}

TEST(FollowPlayback, TakesUpAControllerClockThatRunsSlow) {
  // LinuxCNC's periods 2 % slower than the wall clock (a servo thread that runs late and does not make the
  // periods up): the player slows with them and never runs dry.
  emulators::FollowPlayback p(0.1);
  std::array<double, 4> out{};
  double last = -1;
  for (int k = 1; k <= 3000; ++k) {
    const double wall = k * 0.01;
    std::vector<emulators::FollowFrame> f(10);
    for (int i = 0; i < 10; ++i) {
      auto& fr = f[static_cast<std::size_t>(i)];
      fr.t_s = (wall - 0.009 + i * 0.001) * 0.98;
      fr.bus_m = {fr.t_s, 0, 0, 0};
    }
    p.arrived(wall, f.data(), f.size());
    for (int q = 1; q <= 2; ++q) {
      ASSERT_TRUE(p.at(wall + q * 0.004, out));
      EXPECT_GE(out[0], last);
      last = out[0];
    }
  }
  EXPECT_EQ(p.underruns(), 0u);
  EXPECT_NEAR(30.0 * 0.98 - last, 0.1, 0.02);  // the delay held, in the controller's time
}

TEST(FollowPlayback, TakesTheDelayBackWhereTheMachineStandsStill) {
  // LinuxCNC on a loaded PC stalls (0.8 s) mid-move and does not make the periods up: the stall spends 0.8 s
  // of the 1 s delay for good. The machine then stands still for 3 s (a dwell between the circles): there
  // the player pauses until the delay is whole again, so that the next move survives a stall as long. With
  // the pace alone (20 % slower at most, while the machine moves) the delay is not back in time and the
  // second stall runs the player dry mid-move: the run would be cut.
  emulators::FollowPlayback p(1.0);
  std::array<double, 4> out{};
  double machine_t = 0, last = -1;
  const std::vector<std::pair<double, double>> stalls = {{3.0, 0.8}, {9.5, 0.8}};  // (wall, seconds)
  // Standing at the start (LinuxCNC homed, the program not begun) and from 5 s to 8 s of machine time.
  const auto still = [](double t) { return t < 1.0 || (t >= 5.0 && t < 8.0); };
  std::size_t next_stall = 0;
  for (double wall = 0.01; wall < 13.0; wall += 0.01) {
    if (next_stall < stalls.size() && wall >= stalls[next_stall].first) {
      wall += stalls[next_stall++].second;  // nothing arrives meanwhile; the player plays on
      for (double w = wall - 0.8; w < wall; w += 0.004) {
        ASSERT_TRUE(p.at(w, out));
        EXPECT_GE(out[0], last);
        last = out[0];
      }
    }
    std::vector<emulators::FollowFrame> f(10);
    for (auto& fr : f) {
      machine_t += 0.001;
      fr.t_s = machine_t;
      fr.bus_m = {fr.t_s, 0, 0, 0};
      fr.still = still(fr.t_s);
    }
    p.arrived(wall, f.data(), f.size());
    for (int q = 1; q <= 2; ++q) {
      ASSERT_TRUE(p.at(wall + q * 0.004, out));
      EXPECT_GE(out[0], last);  // never back in time
      last = out[0];
    }
  }
  EXPECT_EQ(p.underruns(), 0u) << "the second stall ran the player dry";
  EXPECT_EQ(p.pauses(), 3u);  // at the start (the delay built up), after the first stall, in the second
}

TEST(MotionStepper, ServoPeriodsGiveWhatSimulateMotionGives) {
  // The machine stepped by 1 ms periods of a commanded path (as LinuxCNC's motor-pos-cmd comes) against the
  // same path simulated at 1 kHz with 0.2 ms steps: the same machine within the steps' difference.
  machine::MachineConfig c = machine::default_machine_config();
  c.noise = {};
  c.dbb.noise_m = 0;
  c.axis[0].encoder_resolution_m = c.axis[1].encoder_resolution_m = 0;
  const machine::Machine m(c);
  const double r = 0.1, omega = 1000.0 / 60e3 / r;
  const auto path = [&](double t) { return machine::Vec3{r * std::cos(omega * t), r * std::sin(omega * t), 0.0}; };
  machine::MotionSpec spec{path, 2.0, 1000.0};
  const auto reference = m.simulate_motion(spec);
  machine::MotionStepper s(m, path(0), 0.0, 0);
  double worst = 0;
  for (std::size_t k = 1; k < reference.size(); ++k) {
    const double t = static_cast<double>(k) * 1e-3;
    for (int q = 1; q <= 5; ++q) {
      const double tq = t - 1e-3 + q * 2e-4;
      s.step(path(tq), tq, 2e-4);
    }
    const auto got = s.sample(path(t), t);
    for (std::size_t j = 0; j < 3; ++j) worst = std::max(worst, std::abs(got.tool[j] - reference[k].tool[j]));
  }
  EXPECT_LT(worst, 1e-12);
}

// The arcs of a program: G2/G3, end points and centre offsets, by plane.
struct Arc {
  std::string g;
  std::map<char, double> w;
};

std::vector<Arc> arcs(const std::string& text) {
  std::vector<Arc> out;
  std::istringstream in(text);
  std::string line;
  const std::regex word("([A-Z])(-?[0-9.]+)");
  while (std::getline(in, line)) {
    const std::string code = line.substr(0, line.find(' '));
    if (code != "G2" && code != "G3") continue;
    Arc a{code, {}};
    const std::string body = line.substr(0, line.find('('));
    for (std::sregex_iterator it(body.begin() + 2, body.end(), word), end; it != end; ++it)
      a.w[(*it)[1].str()[0]] = std::stod((*it)[2].str());
    out.push_back(a);
  }
  return out;
}

TEST(DbbProgram, TheStandardTestsArcsAreOnTheCircleWithTheRightTurn) {
  formats::DbbProgram p;
  p.center_mm = {50, -20, 5};
  p.circles = formats::dbb_test_circles("standard", 100, "xy", 45);
  const std::string text = formats::format_dbb_program(p);
  auto a = arcs(text);
  ASSERT_EQ(a.size(), 6u);  // feed-in, data, feed-out, each run
  for (std::size_t i = 0; i < 3; ++i) EXPECT_EQ(a[i].g, "G3") << text;  // ccw in G17
  for (std::size_t i = 3; i < 6; ++i) EXPECT_EQ(a[i].g, "G2") << text;
  // The feed-in of the ccw run starts at -45 deg; its I J point from there to the centre.
  EXPECT_NE(text.find("G0 X120.710678 Y-90.710678 Z5.000000"), std::string::npos) << text;
  EXPECT_NEAR(a[0].w['I'], -70.710678, 1e-6);
  EXPECT_NEAR(a[0].w['J'], 70.710678, 1e-6);
  EXPECT_NEAR(a[0].w['X'], 150, 1e-6);  // the data arc starts at 0 deg
  EXPECT_NEAR(a[1].w['X'], 150, 1e-6);  // a full circle: its end is its start
  EXPECT_NEAR(a[1].w['Y'], -20, 1e-6);
  EXPECT_NE(text.find("F1000.000000"), std::string::npos);
  EXPECT_NE(text.find("M62 P0"), std::string::npos);
  EXPECT_NE(text.find("M65 P0"), std::string::npos);
  EXPECT_LT(text.find("M62 P0"), text.find("(feed-in)"));
  EXPECT_GT(text.find("M65 P0"), text.rfind("G4 P"));
  EXPECT_NE(text.find("M0 (mount"), std::string::npos);
  EXPECT_NEAR(formats::dbb_program_duration_s(p), 2 * (450 * pi / 180 * 100) / (1000 / 60.0) + 2, 1e-9);
}

TEST(DbbProgram, VerticalPlanesTurnTheirWayAndInchesAreInches) {
  formats::DbbProgram p;
  p.inch = true;
  p.feed_mm_per_min = 254;
  p.circles = formats::dbb_test_circles("three-plane", 101.6, "xy", 45);
  ASSERT_EQ(p.circles.size(), 6u);
  const std::string text = formats::format_dbb_program(p);
  EXPECT_EQ(text.find("G21"), std::string::npos);
  EXPECT_NE(text.find("G20 "), std::string::npos);
  EXPECT_NE(text.find("F10.0000000"), std::string::npos) << text;
  EXPECT_NE(text.find("G18"), std::string::npos);
  EXPECT_NE(text.find("G19"), std::string::npos);
  auto a = arcs(text);
  ASSERT_EQ(a.size(), 18u);
  // xz ccw (x towards z, about -Y) is G2 in G18 (which turns about +Y); yz ccw is G3 in G19.
  EXPECT_EQ(a[6].g, "G2");
  EXPECT_EQ(a[9].g, "G3");
  EXPECT_EQ(a[12].g, "G3");
  // xz ccw's data arc starts at -20 deg and ends at 200 deg, 4 inches out, the feed-in 10 deg.
  EXPECT_NEAR(a[6].w['X'], 4 * std::cos(-20 * pi / 180), 1e-7);
  EXPECT_NEAR(a[6].w['Z'], 4 * std::sin(-20 * pi / 180), 1e-7);
  EXPECT_NEAR(a[7].w['X'], 4 * std::cos(200 * pi / 180), 1e-7);
  EXPECT_NEAR(a[6].w['I'], -4 * std::cos(-30 * pi / 180), 1e-7);
  EXPECT_NEAR(a[6].w['K'], -4 * std::sin(-30 * pi / 180), 1e-7);
}

TEST(DbbProgram, RefusesWhatNoTestIs) {
  formats::DbbProgram p;
  p.circles = formats::dbb_test_circles("standard", 100, "xy", 45);
  p.circles[0].data_arc_deg = 170;
  EXPECT_THROW(formats::format_dbb_program(p), std::invalid_argument);
  p.circles[0].data_arc_deg = 360;
  p.circles[0].plane = "xx";
  EXPECT_THROW(formats::format_dbb_program(p), std::invalid_argument);
  p.circles[0].plane = "xy";
  p.feed_mm_per_min = 0;
  EXPECT_THROW(formats::format_dbb_program(p), std::invalid_argument);
  EXPECT_THROW(formats::dbb_test_circles("lai", 100, "xy", 45), std::invalid_argument);
}

}  // namespace
