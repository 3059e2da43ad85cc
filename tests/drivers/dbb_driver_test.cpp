// dbb-can driver against the DBB emulator through the real CAN transport: can_frame records over
// socketpair(AF_UNIX, SOCK_SEQPACKET) and over the emulator's Unix gateway socket; every fault the
// emulator can inject, with the driver surviving and nothing received before the fault lost.
#include <gtest/gtest.h>
#include <sys/socket.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <thread>

#include "core/mono_clock.hpp"
#include "drivers/dbb/dbb_driver.hpp"
#include "simulators/emulators/can_serial_machine_sources.hpp"
#include "simulators/emulators/dbb_emulator.hpp"
#include "dbb_bench.hpp"
#include "driver_counters_support.hpp"
#include "test_support.hpp"
#include "sanitizer_build.hpp"

using namespace guideway;
using namespace std::chrono_literals;
using drivers::DeviceState;
using drivers::IoLoop;
using test::Bench;
using test::circle_source;
using test::emulator_settings;
using test::three_encoders;

namespace {

// A dbb-can device made by the driver registry from a [[device]] table, as guidewayd makes it: the
// bus is the Unix gateway at `path`, the encoders those of three_encoders(), plus `keys`.
std::unique_ptr<drivers::Driver> driver_from_config(const std::string& path, const std::string& keys) {
  const std::string toml = "[[device]]\nname = \"dbb\"\ndriver = \"dbb-can\"\nbus = \"unix:" + path + "\"\n" + keys +
                           "[[device.encoder]]\nchannel = \"bar_length\"\nnode_id = 1\nresolution_nm = 100\n"
                           "offset_mm = 100\n"
                           "[[device.encoder]]\nchannel = \"x\"\nnode_id = 2\nresolution_nm = 100\n"
                           "[[device.encoder]]\nchannel = \"y\"\nnode_id = 3\nresolution_nm = 50\n"
                           "direction = \"negative\"\nzero_count = 1000\n";
  const toml::table root = parse_toml(toml, "dbb.toml");
  const TableReader top(root, "dbb.toml", "");
  const auto devices = top.tables("device");
  if (devices.size() != 1) throw std::runtime_error("dbb.toml: expected one [[device]]");
  drivers::DriverRegistry registry;
  drivers::dbb::register_dbb_driver(registry);
  (void)devices[0].require_string("name");
  (void)devices[0].require_string("driver");
  auto driver = registry.create({"dbb", "dbb-can", 4096, devices[0]});
  devices[0].reject_unknown_keys();
  return driver;
}

}  // namespace

TEST(DbbDriver, DriverProducesSyncAndEverySampleMatchesTheEmulator) {
  Bench b(true);
  ASSERT_TRUE(b.wait_samples(100));
  const auto st = b.driver->status();
  EXPECT_EQ(st.state, DeviceState::streaming);
  EXPECT_EQ(st.counters.bad_frames, 0u);
  EXPECT_EQ(b.driver->channels().size(), 3u);
  EXPECT_EQ(b.driver->channels()[0].name, "bar_length");
  EXPECT_EQ(b.driver->channels()[0].unit, "m");
  b.stop_and_check_all();
  // The bar reads radius + 3 um.
  EXPECT_NEAR(b.samples.back().value[0], 0.100003, 1e-7);
  // Samples come at the SYNC rate (200 Hz), never faster: late SYNCs are skipped, not bunched. How many
  // are skipped depends on how often this machine lets the driver thread wait (a third of them at load
  // 20 on two cores); that the rate is kept is asserted where the test runs alone (At5kHz*).
  const double span_s = static_cast<double>(b.samples.back().t_mono_ns - b.samples.front().t_mono_ns) * 1e-9;
  const double mean_period_s = span_s / static_cast<double>(b.samples.size() - 1);
  EXPECT_GT(mean_period_s, 0.0045);
}

TEST(DbbDriver, SamplesMatchTheVirtualMachinesDbbCircles) {
  // The demo machine (squareness, servo mismatch, backlash, bar noise) runs DBB circles at a fast feed
  // so the test sees a good part of each; the samples must equal the machine's bar length and plane
  // axis encoders at the emulator's times, to the encoder resolution.
  const simulators::machine::Machine machine(simulators::emulators::demo_machine_config());
  simulators::machine::DbbCircleSpec ccw_xy;
  ccw_xy.radius_m = 0.1;
  ccw_xy.feed_m_per_s = 0.5;
  ccw_xy.sample_rate_hz = 2000.0;
  simulators::machine::DbbCircleSpec cw_xz = ccw_xy;
  cw_xz.direction = guideway::formats::DbbDirection::cw;
  cw_xz.plane = simulators::machine::Plane::xz;
  cw_xz.height_m = 0.03;
  cw_xz.overshoot_rad = 0.3;
  cw_xz.start_angle_rad = 1.0;
  for (const auto& spec : {ccw_xy, cw_xz}) {
    SCOPED_TRACE(spec.plane == simulators::machine::Plane::xy ? "ccw in XY" : "cw in XZ with height");
    auto motion = simulators::emulators::make_dbb_motion(machine, spec);
    ASSERT_GT(motion->duration_s, 1.0);
    Bench b(true, 200.0, 150, simulators::emulators::dbb_motion_source(motion));
    ASSERT_TRUE(b.wait_samples(60));
    // The third node misses three cycles: partial samples holding its channel, as a late answer under
    // load makes them (a sample's channels are not all its cycle's).
    b.emu.inject_drop_pdo(2, 3);
    ASSERT_TRUE(b.wait_samples(150));
    b.stop_and_check_all(3);
    ASSERT_EQ(b.cycle_of.size(), b.samples.size());
    double min_dl = 1, max_dl = -1;
    // Each sample against the machine at the time of the cycle it is (the check's assignment: under load
    // an answer late for the next SYNC may be no sample of its own, or a partial one holding a channel),
    // each channel its cycle sent; a held one (flagged partial) the check found equal to the sample before.
    for (std::size_t i = 0; i < b.samples.size(); ++i) {
      const auto& cycle = b.sent[b.cycle_of[i]];
      double truth[3];
      motion->at(cycle.t_s, truth);
      const double bound[3] = {0.51e-7, 0.51e-7, 0.26e-7};  // encoder scales differ (the third: 50 nm)
      for (std::size_t k = 0; k < 3; ++k) {
        if ((cycle.sent_mask & (1u << k)) == 0) continue;
        const bool held = (b.samples[i].flags & sample_partial) != 0 && i > 0 &&
                          std::abs(b.samples[i].value[k] - b.samples[i - 1].value[k]) <= bound[k];
        if (!held) {
          EXPECT_NEAR(b.samples[i].value[k], truth[k], bound[k]) << "sample " << i << " channel " << k;
        }
      }
      const double dl = b.samples[i].value[0] - motion->run.nominal_length_m;
      min_dl = std::min(min_dl, dl);
      max_dl = std::max(max_dl, dl);
    }
    // The machine's errors show in the bar.
    EXPECT_GT(max_dl - min_dl, 0.2e-6);
    EXPECT_LT(max_dl - min_dl, 10e-3);  // 30 m/min with servo lag mismatches: large, but not absurd
  }
}

TEST(DbbDriver, ListenOnlyFollowsTheControllersSync) {
  for (const std::int64_t read_period_us : {std::int64_t{0}, drivers::dbb::default_read_period_us}) {
    SCOPED_TRACE(read_period_us == 0 ? "a wake-up per frame" : "batched reads");
    Bench b(false, 250.0, 150, circle_source(), read_period_us);
    ASSERT_TRUE(b.wait_samples(100));
    b.stop_and_check_all();
    EXPECT_EQ(b.driver->untimed_frames(), 0u) << "every frame carries its kernel receive time";
  }
}

// Listen mode reading in batches (the default read period) at 1 kHz and 10 kHz emulated SYNC: every
// cycle the emulator sent is one sample, none lost, none merged, in order, at its own SYNC time.
TEST(DbbDriver, ListenBatchedDeliversEveryCycleAt1kAnd10kHz) {
  for (const double rate_hz : {1000.0, 10000.0}) {
    SCOPED_TRACE(rate_hz);
    Bench b(false, rate_hz);
    ASSERT_TRUE(b.wait_samples(rate_hz > 5000 ? 3000 : 500));
    b.stop_and_check_all();
    EXPECT_EQ(b.driver->status().counters.bad_frames, 0u);
    EXPECT_EQ(b.driver->untimed_frames(), 0u);
    // A batch holds several cycles, yet each sample has its own SYNC's time: strictly increasing.
    for (std::size_t i = 1; i < b.samples.size(); ++i) {
      ASSERT_GT(b.samples[i].t_mono_ns, b.samples[i - 1].t_mono_ns) << i;
    }
    // Reads (~wake-ups): at 10 kHz one per 300 us period holds ~3 cycles (asserted where the test runs
    // alone: DbbDriverAlone below). At 1 kHz SYNCs are further apart than the period, so a read that
    // completed its cycle waits for the next SYNC instead of resting and reading an empty socket
    // (about one empty read per cycle if it rested).
    const auto n = static_cast<double>(b.samples.size());
    const double reads_per_sample = static_cast<double>(b.driver->bus_reads()) / n;
    const double empty_reads_per_sample = static_cast<double>(b.driver->empty_reads()) / n;
#if !defined(GUIDEWAY_SANITIZED_THREAD) && !defined(GUIDEWAY_SANITIZED_ADDRESS)  // a slowed emulator changes the ratio
    if (rate_hz < 5000) {
      EXPECT_LT(empty_reads_per_sample, 0.3);
    }
#endif
    const std::string k = rate_hz > 5000 ? "_10k" : "_1k";
    RecordProperty("reads_per_sample" + k, std::to_string(reads_per_sample));
    RecordProperty("empty_reads_per_sample" + k, std::to_string(empty_reads_per_sample));
  }
}

// At 10 kHz SYNC one read per 300 us period takes ~3 cycles. Timing-sensitive (an emulator slowed by
// a competing build answers late and the ratio rises): ctest runs DbbDriverAlone.* on its own.
TEST(DbbDriverAlone, ListenBatchedAt10kHzReadsAboutOncePerPeriod) {
  Bench b(false, 10000.0);
  ASSERT_TRUE(b.wait_samples(3000));
  b.stop_and_check_all();
  const double reads_per_sample =
      static_cast<double>(b.driver->bus_reads()) / static_cast<double>(b.samples.size());
  RecordProperty("reads_per_sample_10k_alone", std::to_string(reads_per_sample));
#if !defined(GUIDEWAY_SANITIZED_THREAD) && !defined(GUIDEWAY_SANITIZED_ADDRESS)  // a slowed emulator changes the ratio
  EXPECT_LT(reads_per_sample, 0.6);
#endif
}

// The proof that samples carry the kernel's receive time of their SYNC, not the read time: reads every
// 20 ms at 1 kHz SYNC (~20 cycles per read). With read-time stamps the median error would be ~10 ms
// and a read's cycles would share one time.
TEST(DbbDriver, ListenBatchedSamplesCarryTheSyncsKernelReceiveTime) {
  constexpr std::int64_t read_period_us = 20'000;
  Bench b(false, 1000.0, 150, circle_source(), read_period_us);
  ASSERT_TRUE(b.wait_samples(300));
  b.stop_and_check_all();
  const auto log = b.emu.log();
  std::vector<simulators::emulators::DbbSentCycle> sent;
  for (const auto& c : log) {
    if (c.sent_mask != 0) sent.push_back(c);
  }
  ASSERT_EQ(sent.size(), b.samples.size());
  std::vector<std::int64_t> error_ns;
  for (std::size_t i = 0; i < sent.size(); ++i) error_ns.push_back(b.samples[i].t_mono_ns - sent[i].t_mono_ns);
  std::vector<std::int64_t> sorted = error_ns;
  std::sort(sorted.begin(), sorted.end());
  const std::int64_t median = sorted[sorted.size() / 2];
  const std::int64_t p90 = sorted[sorted.size() * 9 / 10];
  RecordProperty("stamp_minus_latch_median_us", std::to_string(median / 1000));
  RecordProperty("stamp_minus_latch_p99_us", std::to_string(sorted[sorted.size() * 99 / 100] / 1000));
  RecordProperty("stamp_minus_latch_max_us", std::to_string(sorted.back() / 1000));
  // The emulator takes its time just before the write; the kernel stamps at the write.
  EXPECT_GE(sorted.front(), -50'000) << "a sample time before the SYNC was sent";
  EXPECT_LT(median, 200'000) << "median sample time - SYNC send time, ns";
  EXPECT_LT(p90, 2'000'000) << "90th percentile, ns (read period " << read_period_us << " us)";
  EXPECT_EQ(b.driver->untimed_frames(), 0u);
}

TEST(DbbDriver, FrameTimeIsTheKernelStampOnTheMonotonicClockOrTheReadTime) {
  const std::int64_t offset = 1'700'000'000'000'000'000;  // realtime - monotonic
  const std::int64_t earliest = 5'000'000'000, read = 5'020'000'000;
  // A stamp inside the window: converted.
  auto t = drivers::dbb::frame_time(offset + 5'010'000'000, offset, earliest, read);
  EXPECT_TRUE(t.from_kernel);
  EXPECT_EQ(t.t_ns, 5'010'000'000);
  // No control message: the read time, flagged.
  t = drivers::dbb::frame_time(drivers::can::no_rx_timestamp, offset, earliest, read);
  EXPECT_FALSE(t.from_kernel);
  EXPECT_EQ(t.t_ns, read);
  // The real-time clock was stepped by +2 s between stamp and read (the offset sampled at the read
  // is 2 s larger): the stamp lands before the window, so the read time is used.
  t = drivers::dbb::frame_time(offset + 5'010'000'000, offset + 2'000'000'000, earliest, read);
  EXPECT_FALSE(t.from_kernel);
  EXPECT_EQ(t.t_ns, read);
  // Stepped back by 2 s: after the read, likewise.
  t = drivers::dbb::frame_time(offset + 5'010'000'000, offset - 2'000'000'000, earliest, read);
  EXPECT_FALSE(t.from_kernel);
  // Within the 1 ms slack: accepted, never later than the read.
  t = drivers::dbb::frame_time(offset + read + 300'000, offset, earliest, read);
  EXPECT_TRUE(t.from_kernel);
  EXPECT_EQ(t.t_ns, read);
  t = drivers::dbb::frame_time(offset + earliest - 300'000, offset, earliest, read);
  EXPECT_TRUE(t.from_kernel);
  EXPECT_EQ(t.t_ns, earliest - 300'000);
}

// The kernel filter a SocketCAN bus gets (not exercised here without AF_CAN): SYNC and, of our nodes,
// TPDO1, EMCY, SDO responses and heartbeats exactly, nothing else, checked frame by frame the way the
// kernel matches.
TEST(DbbDriver, TheCanFilterPassesSyncAndOurNodesFramesOnly) {
  drivers::dbb::DbbSettings s;
  s.encoders = three_encoders();
  const auto filters = drivers::dbb::dbb_can_filters(s);
  ASSERT_EQ(filters.size(), 1 + 4 * s.encoders.size());
  const auto passes = [&](canid_t id) {
    return std::any_of(filters.begin(), filters.end(),
                       [&](const can_filter& f) { return (id & f.can_mask) == (f.can_id & f.can_mask); });
  };
  EXPECT_TRUE(passes(0x080));
  for (const auto& e : s.encoders) {
    EXPECT_TRUE(passes(0x180u + e.node_id)) << int(e.node_id);
    EXPECT_FALSE(passes((0x180u + e.node_id) | CAN_RTR_FLAG)) << "a remote request";
    EXPECT_FALSE(passes((0x180u + e.node_id) | CAN_EFF_FLAG)) << "an extended frame";
    EXPECT_FALSE(passes(0x280u + e.node_id)) << "TPDO2";
    EXPECT_TRUE(passes(0x700u + e.node_id)) << "boot-up and heartbeat";
    EXPECT_TRUE(passes(0x080u + e.node_id)) << "EMCY";
    EXPECT_TRUE(passes(0x580u + e.node_id)) << "SDO response";
    EXPECT_FALSE(passes(0x600u + e.node_id)) << "SDO request (another client's)";
  }
  EXPECT_FALSE(passes(0x180u + 100)) << "another node's TPDO1";
  EXPECT_FALSE(passes(0x700u + 100)) << "another node's heartbeat";
  EXPECT_FALSE(passes(0x000)) << "NMT";
}

// The real-time clock stepped back by 2 s in the middle of a batch: the frames stamped before the
// step fall outside the window and the later ones keep their true times. Times never go backwards.
TEST(DbbDriver, FrameTimesNeverGoBackwardsAcrossAClockStep) {
  const std::int64_t offset = 1'700'000'000'000'000'000;  // realtime - monotonic, sampled at the read
  const std::int64_t earliest = 5'000'000'000, read = 5'000'300'000;
  const std::int64_t true_ns[4] = {5'000'050'000, 5'000'100'000, 5'000'150'000, 5'000'200'000};
  std::vector<drivers::dbb::FrameTime> times;
  for (int i = 0; i < 4; ++i) {
    const std::int64_t step = i < 2 ? 2'000'000'000 : 0;  // the first two were stamped before the step
    times.push_back(drivers::dbb::frame_time(offset + true_ns[i] + step, offset, earliest, read));
  }
  ASSERT_FALSE(times[0].from_kernel);
  ASSERT_FALSE(times[1].from_kernel);
  std::int64_t last = earliest - 1'000;
  drivers::dbb::order_frame_times(times, last);
  // Before the step: the first kernel time after them (not the read time, which would put them after it).
  EXPECT_EQ(times[0].t_ns, true_ns[2]);
  EXPECT_EQ(times[1].t_ns, true_ns[2]);
  EXPECT_EQ(times[2].t_ns, true_ns[2]);
  EXPECT_EQ(times[3].t_ns, true_ns[3]);
  EXPECT_EQ(last, true_ns[3]);
  // A batch whose frames all lack a kernel time: the read time.
  std::vector<drivers::dbb::FrameTime> untimed = {
      drivers::dbb::frame_time(drivers::can::no_rx_timestamp, offset, earliest, read)};
  drivers::dbb::order_frame_times(untimed, last);
  EXPECT_EQ(untimed[0].t_ns, read);
  // The next read's kernel times earlier than the last time emitted (here: the read time above) are
  // raised to it.
  std::vector<drivers::dbb::FrameTime> next = {
      drivers::dbb::frame_time(offset + read - 100'000, offset, read - 200'000, read + 300'000),
      drivers::dbb::frame_time(offset + read + 100'000, offset, read - 200'000, read + 300'000)};
  ASSERT_TRUE(next[0].from_kernel);
  drivers::dbb::order_frame_times(next, last);
  EXPECT_EQ(next[0].t_ns, read);
  EXPECT_EQ(next[1].t_ns, read + 100'000);
}

TEST(DbbDriver, GarbageTruncatedBadAndErrorFramesAreCountedAndNothingIsLost) {
  Bench b(true);
  ASSERT_TRUE(b.wait_samples(20));
  b.emu.inject_garbage(25);
  b.emu.inject_truncated(7);
  b.emu.inject_bad_frames(6);
  b.emu.inject_error_frames(4);
  ASSERT_TRUE(test::eventually([&] {
    const auto c = b.driver->status().counters;
    return c.bad_frames >= 7 + 6 + 4;
  }));
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 20));
  const auto st = b.driver->status();
  EXPECT_EQ(st.counters.bad_frames, 7u + 6u + 4u) << "garbage with foreign COB-IDs is not bad, just not ours";
  EXPECT_EQ(b.driver->error_frames(), 4u);
  // The driver's own counters reach STATUS through status(), by name; bus_reads/empty_reads do not.
  const auto own = test::driver_counters_by_name(st);
  EXPECT_EQ(own.size(), 14u);
  EXPECT_EQ(own.at("bus_off"), 0u);  // protocol or controller errors, not bus-off
  EXPECT_TRUE(own.contains("late_pdos"));
  EXPECT_EQ(own.at("syncs_not_sent"), 0u);
  EXPECT_EQ(own.at("error_frames"), 4u);
  EXPECT_EQ(own.at("untimed_frames"), 0u) << "a socketpair bus stamps every frame";
  EXPECT_EQ(own.at("dropped_frames"), 0u);
  EXPECT_EQ(st.state, DeviceState::streaming);
  EXPECT_EQ(st.counters.reconnects, 0u);
  b.stop_and_check_all();
  // Stopped, nothing moves: the published count is the driver's.
  EXPECT_EQ(test::driver_counters_by_name(b.driver->status()).at("partial_cycles"), b.driver->partial_cycles());
}

// Above 2 kHz the driver wakes once per cycle (the PDOs are read just before the next SYNC): the
// same samples, the SYNC period kept with sub-millisecond resolution, faults still seen.
TEST(DbbDriver, At5kHzOneWakeUpPerCycleKeepsTheRateAndEverySample) {
  Bench b(true, 5000.0);
  ASSERT_TRUE(b.wait_samples(1000));
  EXPECT_EQ(b.driver->status().counters.bad_frames, 0u);
  b.stop_and_check_all();
  const double span_s = static_cast<double>(b.samples.back().t_mono_ns - b.samples.front().t_mono_ns) * 1e-9;
  const double mean_period_s = span_s / static_cast<double>(b.samples.size() - 1);
  EXPECT_GT(mean_period_s, 0.00019);  // never faster than 5 kHz
#if !defined(GUIDEWAY_SANITIZED_THREAD) && !defined(GUIDEWAY_SANITIZED_ADDRESS)  // a slowed emulator answers fewer SYNCs
  // Sub-millisecond waits: most samples one period apart, where millisecond waits allowed one a millisecond.
  // The median, not the mean: a loaded machine holds the driver up now and then, and a SYNC slot passed
  // is skipped, not made up (beside three compilers the mean reached 1.24 ms in 22 of 150 runs).
  std::vector<std::int64_t> gaps_ns;
  for (std::size_t i = 1; i < b.samples.size(); ++i) gaps_ns.push_back(b.samples[i].t_mono_ns - b.samples[i - 1].t_mono_ns);
  std::nth_element(gaps_ns.begin(), gaps_ns.begin() + static_cast<std::ptrdiff_t>(gaps_ns.size() / 2), gaps_ns.end());
  EXPECT_LT(gaps_ns[gaps_ns.size() / 2], 500'000) << "median sample period, ns";
#endif
}

TEST(DbbDriver, At5kHzStallsAndDisconnectsAreStillSeen) {
  Bench b(true, 5000.0, 100);
  ASSERT_TRUE(b.wait_samples(100));
  b.emu.inject_stall(0.5);
  ASSERT_TRUE(test::eventually([&] { return b.driver->status().state == DeviceState::lost; }, 3s));
  ASSERT_TRUE(test::eventually([&] { return b.driver->status().state == DeviceState::streaming; }, 5s));
  EXPECT_GE(b.driver->status().counters.timeouts, 1u);
  b.emu.inject_disconnect();
  ASSERT_TRUE(test::eventually([&] { return b.driver->status().counters.reconnects >= 1u; }));
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 100));
  b.stop_and_check_all();
}

TEST(DbbDriver, MissingPdoGivesAPartialSampleHoldingTheLastValue) {
  Bench b(true);
  ASSERT_TRUE(b.wait_samples(10));
  b.emu.inject_drop_pdo(1, 3);
  b.emu.inject_drop_pdo(2, 1);
  ASSERT_TRUE(test::eventually([&] { return b.driver->partial_cycles() >= 3; }));
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 10));
  b.stop_and_check_all(3);
}

// A raw recording under CANopen faults had holes of 14.5 to 84 ms with flags 0: SYNCs no node
// answered (a stall shorter than the timeout, an emulator busy with 2000 EMCYs answering only the
// newest of its queued SYNCs) and SYNC slots a held-up loop came too late for became no sample, and
// nothing said so. The sample after a hole now says it (sample_after_gap, as after a timeout); every
// hole of two periods or more in the driver tests' samples is checked so (Bench::stop_and_check_all).
TEST(DbbDriver, AHoleShorterThanTheTimeoutIsFlaggedOnTheSampleAfterIt) {
  IoLoop loop;
  loop.start("test-io");
  Bench b(true, 200.0, 150, circle_source(), drivers::dbb::default_read_period_us, {}, {}, &loop);
  ASSERT_TRUE(b.wait_samples(20));
  // No node answers for 40 ms (8 SYNCs), well within the 150 ms timeout.
  b.emu.inject_stall(0.04);
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 20));
  // The loop held up for 40 ms: the SYNCs of those slots are never sent.
  loop.post([] { std::this_thread::sleep_for(40ms); });
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 20));
  EXPECT_EQ(b.driver->status().counters.timeouts, 0u);
  std::size_t holes = 0;
  for (std::size_t k = 1; k < b.samples.size(); ++k) {
    if (b.samples[k].t_mono_ns - b.samples[k - 1].t_mono_ns < 30'000'000) continue;
    ++holes;
    EXPECT_TRUE(b.samples[k].flags & sample_after_gap) << "hole before sample " << k;
  }
  EXPECT_GE(holes, 2u);
  b.stop_and_check_all();
  loop.stop();
}

TEST(DbbDriver, StallIsATimeoutThenStreamingResumes) {
  Bench b(true, 200.0, 100);
  ASSERT_TRUE(b.wait_samples(10));
  b.emu.inject_stall(0.5);
  // The driver's own reason (a machine that holds its thread up past twice the timeout may show the
  // sample bound's "no sample for more than 200 ms" first).
  ASSERT_TRUE(test::eventually(
      [&] {
        const auto st = b.driver->status();
        return st.state == DeviceState::lost && st.reason.find("no frames") != std::string::npos;
      },
      3s))
      << b.driver->status().reason;
  ASSERT_TRUE(test::eventually([&] { return b.driver->status().state == DeviceState::streaming; }, 5s));
  const std::size_t before = b.samples.size();
  ASSERT_TRUE(b.wait_samples(before + 20));
  const auto st = b.driver->status();
  EXPECT_GE(st.counters.timeouts, 2u);
  EXPECT_EQ(st.counters.reconnects, 0u);
  // The first sample after the stall says so.
  bool saw_gap = false;
  for (std::size_t i = before > 5 ? before - 5 : 0; i < b.samples.size(); ++i) {
    saw_gap |= (b.samples[i].flags & sample_after_gap) != 0;
  }
  EXPECT_TRUE(saw_gap);
  b.stop_and_check_all();
}

// A bus that takes no more frames (SocketCAN: nobody acknowledges, the transmit queue fills; the gateway:
// a peer that does not read) must not hold up the SYNC producer: it counts the SYNCs it could not send,
// reports the silence, and stops at once.
TEST(DbbDriver, AFullTransmitQueueNeverBlocksTheSyncProducer) {
  int sv[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv), 0);
  drivers::can::CanSocket deaf(sv[1]);  // never read
  bool handed = false;
  drivers::dbb::DbbSettings s;
  s.produce_sync = true;
  s.sync_rate_hz = 5000.0;
  s.timeout_ms = 100;
  s.encoders = three_encoders();
  drivers::dbb::DbbDriver driver("dbb", 1024, s, [&](std::string& err) {
    if (handed) {
      err = "only one connection in this test";
      return drivers::can::CanSocket{};
    }
    handed = true;
    return drivers::can::CanSocket(sv[0]);
  });
  driver.start();
  const auto refused = [&] {
    for (const auto& c : driver.driver_counters())
      if (c.name == "syncs_not_sent") return c.value;
    return std::uint64_t{0};
  };
  ASSERT_TRUE(test::eventually([&] { return refused() > 0; }, 5s)) << "the queue never filled";
  ASSERT_TRUE(test::eventually([&] { return driver.status().state == DeviceState::lost; }, 3s));
  EXPECT_EQ(driver.status().counters.reconnects, 0u) << "a full queue is not a lost connection";
  const auto t0 = std::chrono::steady_clock::now();
  driver.stop();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s) << "stop() waited for the bus";
}

TEST(DbbDriver, DisconnectReconnectsWithBackoffAndKeepsCounting) {
  Bench b(true);
  ASSERT_TRUE(b.wait_samples(20));
  for (int round = 1; round <= 3; ++round) {
    b.emu.inject_disconnect();
    ASSERT_TRUE(
        test::eventually([&] { return b.driver->status().counters.reconnects >= static_cast<unsigned>(round); }));
    ASSERT_TRUE(b.wait_samples(b.samples.size() + 10));
  }
  EXPECT_EQ(b.driver->status().state, DeviceState::streaming);
  EXPECT_EQ(b.connects.load(), 4);
  b.stop_and_check_all();
}

TEST(DbbDriver, BurstFasterThanTheSyncRateIsReceivedCompletely) {
  Bench b(false, 50.0);
  ASSERT_TRUE(b.wait_samples(5));
  b.emu.inject_burst(300);
  ASSERT_TRUE(b.wait_samples(310));
  EXPECT_EQ(b.driver->status().counters.bad_frames, 0u);
  b.stop_and_check_all();
}

TEST(DbbDriver, ReachesTheEmulatorThroughItsUnixGatewayAndComesBackAfterARestart) {
  test::TempDir dir;
  const std::string path = dir.file("can.sock");
  simulators::emulators::DbbEmulator emu(emulator_settings(false, 100.0),
                                         simulators::emulators::ideal_circle_source(0.1, 0.01, -1));
  std::string err;
  auto listener = drivers::can::listen_can_gateway(path, err);
  ASSERT_TRUE(listener.valid()) << err;
  emu.start(std::move(listener));

  auto driver = driver_from_config(path, "sync = \"produce\"\nsync_rate_hz = 200\nreconnect_min_ms = 10\n");
  driver->start();
  ASSERT_TRUE(test::eventually([&] { return driver->ring().depth() >= 20; }));
  // The emulator process goes away and comes back: the driver reconnects.
  emu.stop();
  ASSERT_TRUE(test::eventually([&] { return driver->status().state != DeviceState::streaming; }));
  simulators::emulators::DbbEmulator emu2(emulator_settings(false, 100.0),
                                          simulators::emulators::ideal_circle_source(0.1, 0.01, -1));
  listener = drivers::can::listen_can_gateway(path, err);
  ASSERT_TRUE(listener.valid()) << err;
  emu2.start(std::move(listener));
  ASSERT_TRUE(test::eventually([&] { return driver->status().counters.reconnects >= 1 && emu2.cycles_sent() >= 10; }));
  emu2.stop();
  const std::size_t sent = emu.log().size() + emu2.log().size();
  test::eventually([&] { return driver->ring().depth() >= sent; });
  driver->stop();
  std::vector<Sample> got(driver->ring().depth());
  got.resize(driver->ring().pop_bulk(got));
  EXPECT_EQ(got.size(), sent);
  for (std::size_t i = 1; i < got.size(); ++i) EXPECT_EQ(got[i].seq, got[i - 1].seq + 1);
}

// Listen mode from a TOML table, through the emulator's Unix gateway (an accept()ed SEQPACKET socket):
// reads every 5 ms, yet every sample at its SYNC's kernel receive time.
TEST(DbbDriver, ListensThroughTheUnixGatewayWithKernelTimesFromAConfigTable) {
  test::TempDir dir;
  const std::string path = dir.file("can.sock");
  simulators::emulators::DbbEmulator emu(emulator_settings(true, 1000.0),
                                         simulators::emulators::ideal_circle_source(0.1, 0.01, -1));
  std::string err;
  auto listener = drivers::can::listen_can_gateway(path, err);
  ASSERT_TRUE(listener.valid()) << err;
  emu.start(std::move(listener));
  auto driver = driver_from_config(path, "sync = \"listen\"\nread_period_us = 5000\n");
  auto* dbb_driver = dynamic_cast<drivers::dbb::DbbDriver*>(driver.get());
  ASSERT_NE(dbb_driver, nullptr);
  EXPECT_EQ(dbb_driver->settings().read_period_us, 5000);
  driver->start();
  ASSERT_TRUE(test::eventually([&] { return driver->ring().depth() >= 200; }));
  emu.stop();
  const auto log = emu.log();
  std::vector<simulators::emulators::DbbSentCycle> sent;
  for (const auto& c : log) {
    if (c.sent_mask != 0) sent.push_back(c);
  }
  // Every cycle sent on the connection is read; a sample still missing would shift the match below.
  ASSERT_TRUE(test::eventually([&] { return driver->ring().depth() >= sent.size(); }));
  driver->stop();
  std::vector<Sample> got(driver->ring().depth());
  got.resize(driver->ring().pop_bulk(got));
  // The emulator may have sent cycles before the driver connected (nobody read them): match the tail.
  ASSERT_GE(sent.size(), got.size());
  ASSERT_GE(got.size(), 200u);
  const std::size_t skip = sent.size() - got.size();
  std::vector<std::int64_t> error_ns;
  for (std::size_t i = 0; i < got.size(); ++i) {
    // The nodes are started one by one after the connection: a first cycle may lack x's PDO, and its
    // sample holds x (NaN before x ever answered).
    if (sent[skip + i].sent_mask & 0b010u) {
      EXPECT_NEAR(got[i].value[1], sent[skip + i].truth_m[1], 0.51e-7) << i;
    } else {
      const double held = i > 0 ? got[i - 1].value[1] : NAN;
      EXPECT_TRUE(std::isnan(held) ? std::isnan(got[i].value[1]) : got[i].value[1] == held) << i;
    }
    error_ns.push_back(got[i].t_mono_ns - sent[skip + i].t_mono_ns);
  }
  std::sort(error_ns.begin(), error_ns.end());
  EXPECT_LT(error_ns[error_ns.size() / 2], 200'000) << "median sample time - SYNC send time, ns (reads every 5 ms)";
  EXPECT_EQ(dbb_driver->untimed_frames(), 0u);
}

TEST(DbbDriver, ConfigErrorsNameFileLineAndKey) {
  auto create = [](const std::string& body) {
    const toml::table root = parse_toml("[[device]]\nname = \"d\"\ndriver = \"dbb-can\"\n" + body, "bad.toml");
    const TableReader top(root, "bad.toml", "");
    const auto devices = top.tables("device");
    drivers::DriverRegistry registry;
    drivers::dbb::register_dbb_driver(registry);
    return registry.create({"d", "dbb-can", 1024, devices[0]});
  };
  try {
    create("bus = \"unix:/x\"\n");
    FAIL() << "no encoders accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("encoder"), std::string::npos) << e.what();
  }
  try {
    create("bus = \"unix:/x\"\n[[device.encoder]]\nchannel = \"x\"\nnode_id = 200\nresolution_nm = 1\n");
    FAIL() << "node 200 accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.toml:7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("node_id"), std::string::npos) << e.what();
  }
  try {
    create(
        "bus = \"unix:/x\"\nsync = \"sometimes\"\n[[device.encoder]]\nchannel = \"x\"\nnode_id = 2\nresolution_nm = "
        "1\n");
    FAIL() << "bad sync accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("sync"), std::string::npos) << e.what();
  }
  const std::string encoder = "[[device.encoder]]\nchannel = \"x\"\nnode_id = 2\nresolution_nm = 1\n";
  const struct {
    std::string body;
    std::string line;
    std::string why;
  } bad_periods[] = {
      {"bus = \"unix:/x\"\nsync = \"listen\"\nread_period_us = -5\n", "bad.toml:6", "outside"},
      {"bus = \"unix:/x\"\nsync = \"listen\"\nread_period_us = 1000000\n", "bad.toml:6", "outside"},
      {"bus = \"unix:/x\"\nsync = \"listen\"\nread_period_us = 2.5\n", "bad.toml:6", "read_period_us"},
      {"bus = \"unix:/x\"\nsync = \"listen\"\ntimeout_ms = 10\nread_period_us = 10000\n", "bad.toml:7",
       "shorter than timeout_ms"},
      {"bus = \"unix:/x\"\nsync = \"produce\"\nread_period_us = 300\n", "bad.toml:6", "listen"},
  };
  for (const auto& bad : bad_periods) {
    try {
      create(bad.body + encoder);
      ADD_FAILURE() << "accepted: " << bad.body;
    } catch (const ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(bad.line), std::string::npos) << what;
      EXPECT_NE(what.find("read_period_us"), std::string::npos) << what;
      EXPECT_NE(what.find(bad.why), std::string::npos) << what;
    }
  }
  // Accepted: 0 (a wake-up per frame) and the largest period below the timeout.
  EXPECT_NO_THROW(create("bus = \"unix:/x\"\nsync = \"listen\"\nread_period_us = 0\n" + encoder));
  EXPECT_NO_THROW(
      create("bus = \"unix:/x\"\nsync = \"listen\"\ntimeout_ms = 10\nread_period_us = 9999\n" + encoder));
}

TEST(DbbDriver, StartsAgainAfterStop) {
  Bench b(true);
  ASSERT_TRUE(b.wait_samples(10));
  b.driver->stop();
  EXPECT_EQ(b.driver->status().state, DeviceState::stopped);
  b.driver->start();
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 10));
  EXPECT_EQ(b.driver->status().state, DeviceState::streaming);
  for (std::size_t i = 1; i < b.samples.size(); ++i) EXPECT_EQ(b.samples[i].seq, b.samples[i - 1].seq + 1);
}

// Bus-off is an error state that lasts until the controller has restarted (the daemon polls device
// states every 50 ms: set back by the next cycle, it lasted ~4 ms and no EVENT or log line showed it),
// and the recovery says how long the bus was off.
// A controller that restarts while its nodes are still quiet (here muted past the restart): the device
// is lost for a while, then streams; the state that says it streams again still tells how the bus-off
// ended, since nobody saw the recovery in between.
TEST(DbbDriver, TheRecoveryFromBusOffIsToldWhenStreamingResumesAfterAQuietSpell) {
  Bench b(false, 100.0);
  ASSERT_TRUE(b.wait_samples(10));
  b.emu.inject_bus_off(200);
  for (std::size_t i = 0; i < 3; ++i) b.emu.inject_mute(i, 0.6);
  ASSERT_TRUE(test::eventually([&] { return b.driver->error_frames() == 1; }));
  ASSERT_TRUE(test::eventually([&] { return b.driver->status().state == DeviceState::lost; }))
      << b.driver->status().reason;
  ASSERT_TRUE(test::eventually([&] { return b.driver->status().state == DeviceState::streaming; }));
  const auto on = b.driver->status();
  EXPECT_NE(on.reason.find("recovered from bus-off after"), std::string::npos) << on.reason;
  b.stop_and_check_all();
}

TEST(DbbDriver, BusOffLatchesTheErrorStateUntilTheControllerRestarts) {
  Bench b(false, 100.0);
  ASSERT_TRUE(b.wait_samples(10));
  b.emu.inject_bus_off(300);
  ASSERT_TRUE(test::eventually([&] { return b.driver->error_frames() == 1; }));
  const auto off = b.driver->status();
  EXPECT_EQ(off.state, DeviceState::error);
  EXPECT_EQ(off.reason, "CAN bus off");
  std::this_thread::sleep_for(std::chrono::milliseconds(150));  // still off: the bus is silent
  EXPECT_EQ(b.driver->status().state, DeviceState::error);
  ASSERT_TRUE(test::eventually([&] { return b.driver->status().state == DeviceState::streaming; }));
  const auto on = b.driver->status();
  EXPECT_NE(on.reason.find("recovered from bus-off after"), std::string::npos) << on.reason;
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 10));
  EXPECT_EQ(b.driver->status().counters.bad_frames, 1u);  // the restart notice is not an error
  std::uint64_t bus_off = 0;
  for (const auto& c : b.driver->driver_counters())
    if (c.name == "bus_off") bus_off = c.value;
  EXPECT_EQ(bus_off, 1u);
  b.stop_and_check_all();
}
