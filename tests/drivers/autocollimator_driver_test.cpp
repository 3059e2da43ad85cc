// autocollimator-serial driver against the autocollimator emulator through a real pseudo-terminal
// (termios backend), the emulator's readings coming from the virtual machine tool's traverse; every
// fault the emulator can inject, with the driver surviving and nothing delivered lost.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <memory>
#include <thread>

#include "drivers/autocollimator/autocollimator_driver.hpp"
#include "simulators/emulators/autocollimator_emulator.hpp"
#include "simulators/emulators/can_serial_machine_sources.hpp"
#include "test_support.hpp"

using namespace guideway;
using namespace std::chrono_literals;
using drivers::DeviceState;
using drivers::autocollimator::arcsec_to_rad;
using drivers::autocollimator::AxisState;

namespace {

std::shared_ptr<const simulators::emulators::TraverseMotion> traverse() {
  static const auto motion = [] {
    const simulators::machine::Machine machine(simulators::emulators::demo_machine_config());
    simulators::machine::TraverseSpec spec;
    spec.start_m = 0.0;
    spec.end_m = 0.5;
    spec.step_m = 0.05;
    spec.dwell_s = 0.05;
    return simulators::emulators::make_traverse_motion(machine, spec);
  }();
  return motion;
}

struct Bench {
  explicit Bench(bool stream, bool checksum = false, simulators::emulators::AutocollimatorSource source = {},
                 double range_arcsec = 1000.0)
      : emu({range_arcsec, checksum, dir.file("ac0")},
            source ? source : simulators::emulators::traverse_source(traverse())) {
    std::string err;
    if (!emu.start(err)) throw std::runtime_error(err);
    drivers::autocollimator::AutocollimatorSettings s;
    s.serial.port = emu.path();
    s.serial.baud_rate = 115200;
    s.stream = stream;
    s.poll_period_ms = 5;
    s.stream_period_ms = 5;
    s.reply_timeout_ms = 100;
    s.lost_after_timeouts = 2;
    s.require_checksum = checksum;
    s.reconnect.backoff = Backoff::between(std::chrono::milliseconds(10), std::chrono::milliseconds(100));
    s.x_channel = "yaw";
    s.y_channel = "pitch";
    driver = std::make_unique<drivers::autocollimator::AutocollimatorDriver>("ac", 1 << 14, s);
    driver->start();
  }
  ~Bench() {
    driver->stop();
    emu.stop();
  }
  void drain() {
    Sample s;
    while (driver->ring().try_pop(s)) samples.push_back(s);
  }
  bool wait_samples(std::size_t n, std::chrono::milliseconds timeout = 10s) {
    return test::eventually(
        [&] {
          drain();
          return samples.size() >= n;
        },
        timeout);
  }
  // Silences the emulator first and lets the driver read everything it wrote, then checks every
  // reading sent against the samples.
  void stop_and_check_all() {
    emu.inject_stall(1e6);
    ASSERT_TRUE(emu.settle()) << "the emulator thread made no progress";  // a reading under way is logged
    const auto log = emu.log();
    test::eventually([&] {
      drain();
      return samples.size() >= log.size();
    });
    driver->stop();
    emu.stop();
    drain();
    ASSERT_EQ(samples.size(), log.size()) << "every reading put on the line becomes exactly one sample";
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const Sample& s = samples[i];
      EXPECT_EQ(s.seq, i);
      ASSERT_EQ(s.value_count, 2u);
      if (i > 0) {
        EXPECT_GE(s.t_mono_ns, samples[i - 1].t_mono_ns) << i;
      }
      const auto& r = log[i].reading;
      if (r.x_state == AxisState::valid) {
        EXPECT_NEAR(s.value[0], r.x_arcsec * arcsec_to_rad, 1e-12) << i;
      } else {
        EXPECT_TRUE(std::isnan(s.value[0])) << i;
      }
      if (r.y_state == AxisState::valid) {
        EXPECT_NEAR(s.value[1], r.y_arcsec * arcsec_to_rad, 1e-12) << i;
      } else {
        EXPECT_TRUE(std::isnan(s.value[1])) << i;
      }
    }
  }

  test::TempDir dir;
  simulators::emulators::AutocollimatorEmulator emu;
  std::unique_ptr<drivers::autocollimator::AutocollimatorDriver> driver;
  std::vector<Sample> samples;
};

}  // namespace

TEST(AutocollimatorDriver, PolledReadingsMatchTheMachinesTraverse) {
  Bench b(false);
  ASSERT_TRUE(b.wait_samples(100));
  EXPECT_EQ(b.driver->status().state, DeviceState::streaming);
  EXPECT_EQ(b.driver->channels()[0].name, "yaw");
  EXPECT_EQ(b.driver->channels()[1].unit, "rad");
  b.stop_and_check_all();
  // Independently of the emulator's log: the machine's traverse at the emulator's times, to 0.01".
  const auto log = b.emu.log();
  std::size_t stations_seen = 0;
  double last_pos = -1;
  for (std::size_t i = 0; i < log.size(); ++i) {
    const auto& st = traverse()->at(log[i].t_s);
    EXPECT_NEAR(b.samples[i].value[0], st.yaw_rad, 0.0051 * arcsec_to_rad) << i;
    EXPECT_NEAR(b.samples[i].value[1], st.pitch_rad, 0.0051 * arcsec_to_rad) << i;
    if (st.position_m != last_pos) ++stations_seen;
    last_pos = st.position_m;
  }
  EXPECT_GE(stations_seen, 3u) << "the traverse moved through several stops";
}

TEST(AutocollimatorDriver, StreamedReadingsArriveInOrder) {
  Bench b(true);
  ASSERT_TRUE(b.wait_samples(100));
  EXPECT_TRUE(b.emu.streaming());
  b.stop_and_check_all();
}

TEST(AutocollimatorDriver, GarbageTruncatedAndBadChecksumLinesAreCountedNotPublished) {
  Bench b(false, true);
  ASSERT_TRUE(b.wait_samples(10));
  b.emu.inject_garbage(200);
  b.emu.inject_truncated(5);
  b.emu.inject_bad_checksum(4);
  ASSERT_TRUE(test::eventually([&] { return b.driver->status().counters.bad_frames >= 10; }));
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 20));
  const auto st = b.driver->status();
  EXPECT_EQ(st.state, DeviceState::streaming);
  EXPECT_EQ(st.counters.reconnects, 0u);
  b.stop_and_check_all();
}

TEST(AutocollimatorDriver, StallCountsTimeoutsGoesLostAndRecovers) {
  for (const bool stream : {false, true}) {
    SCOPED_TRACE(stream ? "stream" : "poll");
    Bench b(stream);
    ASSERT_TRUE(b.wait_samples(10));
    // Silent until the driver has said it is lost (two 100 ms timeouts), however late this machine
    // lets its thread see them; then answering again.
    b.emu.inject_stall(1e6);
    // The driver's own reason (a machine that holds its thread up may show the sample bound's "no
    // sample for more than N ms" first).
    ASSERT_TRUE(test::eventually(
        [&] {
          const auto st = b.driver->status();
          return st.state == DeviceState::lost && st.reason.find("no reply") != std::string::npos;
        },
        3s))
        << b.driver->status().reason;
    b.emu.inject_stall(0.0);
    ASSERT_TRUE(test::eventually([&] { return b.driver->status().state == DeviceState::streaming; }, 5s));
    const std::size_t before = b.samples.size();
    ASSERT_TRUE(b.wait_samples(before + 10));
    EXPECT_GE(b.driver->status().counters.timeouts, 2u);
    bool gap = false;
    for (std::size_t i = before; i < b.samples.size(); ++i) gap |= (b.samples[i].flags & sample_after_gap) != 0;
    EXPECT_TRUE(gap);
    b.stop_and_check_all();
  }
}

TEST(AutocollimatorDriver, DisconnectReopensThePortWithBackoffAndLosesNothing) {
  for (const bool stream : {false, true}) {
    SCOPED_TRACE(stream ? "stream" : "poll");
    Bench b(stream);
    ASSERT_TRUE(b.wait_samples(20));
    const std::string first_pty = b.emu.pty_path();
    for (int round = 1; round <= 2; ++round) {
      b.emu.inject_disconnect(0.15);
      ASSERT_TRUE(test::eventually([&] { return b.driver->status().state == DeviceState::lost; }, 3s));
      ASSERT_TRUE(
          test::eventually([&] { return b.driver->status().counters.reconnects >= static_cast<unsigned>(round); }, 5s));
      ASSERT_TRUE(b.wait_samples(b.samples.size() + 10));
    }
    EXPECT_EQ(b.emu.opens(), 3u);
    EXPECT_EQ(b.driver->status().state, DeviceState::streaming);
    b.stop_and_check_all();
  }
}

// Unplugged, the stable name disappears (as a by-id link does): left pointing at the freed
// /dev/pts/N, it would lead the reconnecting driver to whichever pty the kernel hands N next.
TEST(AutocollimatorDriver, WhileUnpluggedTheLinkIsGoneAndTheDriverSaysSo) {
  Bench b(false);
  ASSERT_TRUE(b.wait_samples(5));
  const std::string link = b.dir.file("ac0");
  ASSERT_TRUE(std::filesystem::is_symlink(link));
  b.emu.inject_disconnect(1e6);
  ASSERT_TRUE(test::eventually([&] { return !std::filesystem::exists(std::filesystem::symlink_status(link)); }));
  ASSERT_TRUE(test::eventually([&] {
    const auto st = b.driver->status();
    return st.state == DeviceState::lost && st.reason.find("No such file") != std::string::npos;
  })) << b.driver->status().reason;
}

TEST(AutocollimatorDriver, BurstFasterThanThePollRateIsReceivedCompletely) {
  Bench b(false);
  ASSERT_TRUE(b.wait_samples(5));
  b.emu.inject_burst(400);
  ASSERT_TRUE(b.wait_samples(410));
  EXPECT_EQ(b.driver->status().counters.bad_frames, 0u);
  b.stop_and_check_all();
}

TEST(AutocollimatorDriver, NoReflectionAndOutOfRangeAreFlagsNotNumbers) {
  // A mirror tilting through the 600" range on X, 20" per reading: readings 0-4 over the range, 5-65
  // within it, then over again. Stepped per reading, not per second, so that a slow start or a late
  // reply on a loaded machine cannot carry it through the range unread.
  auto readings = std::make_shared<std::atomic<int>>(0);
  Bench b(
      false, false,
      [readings](double) {
        return simulators::emulators::AutocollimatorView{-700.0 + 20.0 * (*readings)++, 12.5, true};
      },
      600.0);
  ASSERT_TRUE(b.wait_samples(30));
  b.emu.inject_block(1e6);  // the beam blocked until a blind reading was seen, however late it comes
  ASSERT_TRUE(test::eventually([&] {
    b.drain();
    for (const auto& s : b.samples) {
      if (s.flags & sample_no_signal) return true;
    }
    return false;
  }));
  b.emu.inject_block(0.0);
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 10));
  std::size_t over = 0, blind = 0, valid = 0;
  for (const auto& s : b.samples) {
    if (s.flags & sample_out_of_range) {
      ++over;
      EXPECT_TRUE(std::isnan(s.value[0]));
      EXPECT_NEAR(s.value[1], 12.5 * arcsec_to_rad, 1e-12);
    } else if (s.flags & sample_no_signal) {
      ++blind;
      EXPECT_TRUE(std::isnan(s.value[0]) && std::isnan(s.value[1]));
    } else {
      ++valid;
      EXPECT_LE(std::fabs(s.value[0]), 600.0 * arcsec_to_rad);
    }
  }
  EXPECT_GT(over, 0u);
  EXPECT_GT(blind, 0u);
  EXPECT_GT(valid, 0u);
  b.stop_and_check_all();
}

TEST(AutocollimatorDriver, CreatedFromConfigThroughTheRegistry) {
  test::TempDir dir;
  simulators::emulators::AutocollimatorEmulator emu({1000.0, false, dir.file("ac")},
                                                    simulators::emulators::traverse_source(traverse()));
  std::string err;
  ASSERT_TRUE(emu.start(err)) << err;
  const std::string text = "[[device]]\nname = \"ac\"\ndriver = \"autocollimator-serial\"\nport = \"" + emu.path() +
                           "\"\nbaud_rate = 19200\nframing = \"8E1\"\nmode = \"stream\"\nstream_period_ms = 10\n"
                           "x_channel = \"yaw\"\ny_channel = \"pitch\"\n";
  const toml::table root = parse_toml(text, "ac.toml");
  const TableReader top(root, "ac.toml", "");
  const auto devices = top.tables("device");
  drivers::DriverRegistry registry;
  drivers::autocollimator::register_autocollimator_driver(registry);
  (void)devices[0].require_string("name");
  (void)devices[0].require_string("driver");
  auto driver = registry.create({"ac", "autocollimator-serial", 1024, devices[0]});
  devices[0].reject_unknown_keys();
  driver->start();
  EXPECT_TRUE(test::eventually([&] { return driver->ring().depth() >= 20; }));
  driver->stop();
  emu.stop();

  const toml::table bad = parse_toml(
      "[[device]]\nname = \"ac\"\ndriver = \"autocollimator-serial\"\nport = \"/dev/null\"\nbaud_rate = 12345\n",
      "bad.toml");
  const TableReader bad_top(bad, "bad.toml", "");
  try {
    registry.create({"ac", "autocollimator-serial", 1024, bad_top.tables("device")[0]});
    FAIL() << "baud rate 12345 accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.toml:5"), std::string::npos) << e.what();
  }
}

TEST(AutocollimatorDriver, AMissingPortIsAnErrorStateWithTheReasonAndRetries) {
  drivers::autocollimator::AutocollimatorSettings s;
  s.serial.port = "/nonexistent/tty-guideway";
  s.reconnect.backoff = Backoff::between(std::chrono::milliseconds(5), std::chrono::milliseconds(20));
  drivers::autocollimator::AutocollimatorDriver d("ac", 64, s);
  d.start();
  ASSERT_TRUE(test::eventually([&] { return d.status().state == DeviceState::error; }));
  EXPECT_NE(d.status().reason.find("No such file"), std::string::npos) << d.status().reason;
  d.stop();
}
