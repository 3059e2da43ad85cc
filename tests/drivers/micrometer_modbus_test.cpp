// The micrometer-modbus driver against the emulated gauge amplifier through real libmodbus on both
// sides: Modbus TCP on loopback and Modbus RTU over pseudo-terminals. Every fault is injected; the
// driver must count it, recover, and lose nothing it had received.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>
#include <thread>

#include "core/mono_clock.hpp"
#include "busy_loop_support.hpp"
#include "core/sample.hpp"
#include "driver_counters_support.hpp"
#include "drivers/micrometer/micrometer_driver.hpp"
#include "simulators/emulators/micrometer_machine_source.hpp"
#include "simulators/emulators/modbus_emulator.hpp"
#include "test_support.hpp"

using namespace guideway;
using namespace std::chrono_literals;
using simulators::emulators::MicrometerEmulator;
using simulators::emulators::ModbusFault;

namespace {

// Starts the emulator on Modbus RTU (a pty) or TCP; returns the device keys that reach it.
std::string start_transport(MicrometerEmulator& emulator, bool rtu) {
  std::string error;
  if (rtu) {
    const std::string path = emulator.start_rtu(19200, 'E', 8, 1, error);
    if (path.empty()) throw std::runtime_error(error);
    return "transport = \"rtu\"\ndevice = \"" + path + "\"\n";
  }
  const int port = emulator.start_tcp("127.0.0.1", 0, error);
  if (port < 0) throw std::runtime_error(error);
  return "transport = \"tcp\"\nhost = \"127.0.0.1\"\nport = " + std::to_string(port) + "\n";
}

struct Harness {
  explicit Harness(bool rtu,
                   simulators::emulators::MicrometerSource source = simulators::emulators::runout_source(120.0),
                   bool answers_report_server_id = true, std::chrono::milliseconds late_answer_ms = 700ms) {
    MicrometerEmulator::Options o;
    o.source = std::move(source);
    o.answers_report_server_id = answers_report_server_id;
    o.late_answer_ms = late_answer_ms;
    emulator = std::make_unique<MicrometerEmulator>(o);
    const std::string transport = start_transport(*emulator, rtu);
    table = parse_toml(transport +
                           "poll_hz = 100\nresponse_timeout_ms = 400\nlost_after_failures = 3\n"
                           "reconnect_min_ms = 50\nreconnect_max_ms = 400\n[registers]\nvalue_type = \"int32\"\n",
                       "test.toml");
    TableReader reader(table, "test.toml", "device[0]");
    driver = std::make_unique<drivers::micrometer::MicrometerDriver>(
        "mic", drivers::micrometer::parse_micrometer_config(reader), 1 << 14);
    reader.reject_unknown_keys();
  }
  ~Harness() {
    driver->stop();
    emulator->stop();
  }
  void drain() {
    Sample s;
    while (driver->ring().try_pop(s)) samples.push_back(s);
  }
  bool wait_samples(std::size_t n) {
    return test::eventually([&] {
      drain();
      return samples.size() >= n;
    });
  }
  // Every published reading is one the emulator answered normally, in order, with the same value and
  // flags (never a late answer, which the emulator does not log, nor one published twice), and
  // timestamps are strictly increasing. A reading answered but not published is one this machine
  // held up past the response timeout (through a pty on a loaded machine, for up to a second): the
  // driver discarded it when it came and counted its read as a timeout or bad frame; no more of them
  // than those. On a quiet machine none is skipped.
  void expect_matches_served() {
    driver->stop();
    drain();
    // The emulator logs an answer after sending it: the driver may already have published it.
    (void)test::eventually([&] { return emulator->served().size() >= samples.size(); });
    const auto served = emulator->served();
    const auto st = driver->status();
    const auto same = [](const Sample& s, const simulators::emulators::ServedReading& r) {
      if ((s.flags & ~std::uint32_t{sample_after_gap}) != r.flags) return false;
      return r.flags == 0 ? s.value[0] == r.value_m : std::isnan(s.value[0]);
    };
    std::size_t j = 0;  // the next served reading
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const Sample& s = samples[i];
      EXPECT_EQ(s.seq, i);
      ASSERT_EQ(s.value_count, 1u);
      while (j < served.size() && !same(s, served[j])) ++j;
      ASSERT_LT(j, served.size()) << "sample " << i << " (" << s.value[0]
                                  << ") is no reading the emulator answered in time, or is out of order";
      ++j;
      if (i > 0) {
        EXPECT_GT(s.t_mono_ns, samples[i - 1].t_mono_ns);
      }
    }
    EXPECT_LE(served.size() - samples.size(), st.counters.timeouts + st.counters.bad_frames)
        << "readings answered but not published, beyond the failed reads counted";
  }

  toml::table table;
  std::unique_ptr<MicrometerEmulator> emulator;
  std::unique_ptr<drivers::micrometer::MicrometerDriver> driver;
  std::vector<Sample> samples;
};

class MicrometerTransport : public ::testing::TestWithParam<bool> {};

// Every answer a value of its own (the number of the request, in 10 nm counts): a late answer, which
// the emulator does not log as served, can never pass for a reading it served.
simulators::emulators::MicrometerSource counting_source() {
  auto n = std::make_shared<std::atomic<int>>(0);
  return [n](double) { return simulators::emulators::MicrometerPoint{(*n)++ * 1e-8}; };
}

}  // namespace

TEST_P(MicrometerTransport, StreamsWhatTheAmplifierShows) {
  Harness h(GetParam());
  h.driver->start();
  ASSERT_TRUE(h.wait_samples(60));
  EXPECT_EQ(h.driver->status().state, drivers::DeviceState::streaming);
  h.expect_matches_served();
  // A 2 um run-out at 120 rpm sampled at 100 Hz for >0.6 s spans most of the +-2.3 um range.
  double lo = 1, hi = -1;
  for (const Sample& s : h.samples) {
    lo = std::min(lo, s.value[0]);
    hi = std::max(hi, s.value[0]);
  }
  EXPECT_GT(hi - lo, 2e-6);
  EXPECT_LT(hi - lo, 4.7e-6);
  const auto st = h.driver->status();
  EXPECT_EQ(st.counters.bad_frames, 0u);
  EXPECT_EQ(st.counters.timeouts, 0u);
  EXPECT_EQ(st.counters.frames, h.samples.size());
}

TEST_P(MicrometerTransport, FlagsOutOfRangeAndMissingProbe) {
  std::atomic<int> n{0};
  Harness h(GetParam(), [&n](double) {
    const int i = n++;
    return simulators::emulators::MicrometerPoint{i * 1e-8, (i / 10) % 3 == 1, (i / 10) % 3 == 2};
  });
  h.driver->start();
  ASSERT_TRUE(h.wait_samples(40));
  h.expect_matches_served();
  int oor = 0, missing = 0;
  for (const Sample& s : h.samples) {
    oor += (s.flags & sample_out_of_range) ? 1 : 0;
    missing += (s.flags & sample_no_signal) ? 1 : 0;
  }
  EXPECT_GE(oor, 10);
  EXPECT_GE(missing, 10);
}

TEST_P(MicrometerTransport, SurvivesEveryFaultAndLosesNothing) {
  Harness h(GetParam());
  h.driver->start();
  ASSERT_TRUE(h.wait_samples(10));
  auto counters = [&] { return h.driver->status().counters; };
  struct Step {
    ModbusFault fault;
    bool counts_bad;  // else counts a timeout
  };
  const bool rtu = GetParam();
  for (const Step step :
       {Step{ModbusFault::burst, true}, Step{ModbusFault::exception, true}, Step{ModbusFault::stall, false},
        Step{ModbusFault::bad_crc, true}, Step{ModbusFault::truncate, false}, Step{ModbusFault::garbage, true},
        Step{ModbusFault::burst, true}}) {
    SCOPED_TRACE(std::string(simulators::emulators::to_string(step.fault)));
    const auto before = counters();
    const std::size_t have = h.samples.size();
    h.emulator->inject(step.fault, 1);
    ASSERT_TRUE(h.wait_samples(have + 15));
    const auto after = counters();
    // The fault is counted. Lower bounds: an answer that this machine holds up past the 400 ms timeout
    // (through a pty on a loaded machine, for up to a second) is a timeout, or a bad frame when a byte
    // timeout cuts it, like any other and counted besides; on a quiet machine the counts are exact.
    // Nothing duplicated or lost is checked against the emulator's log at the end.
    const auto bad = after.bad_frames - before.bad_frames;
    const auto timeouts = after.timeouts - before.timeouts;
    if (step.fault == ModbusFault::burst) {
      // Extra answers are discarded before the next request: not counted (on a quiet machine).
    } else if (step.fault == ModbusFault::garbage || (rtu && step.fault == ModbusFault::truncate)) {
      EXPECT_GE(bad + timeouts, 1u);  // rejected (bad frame) or waited out (timeout), depending on the bytes
    } else if (step.counts_bad) {
      EXPECT_GE(bad, 1u);
    } else {
      EXPECT_GE(timeouts, 1u);
    }
    EXPECT_EQ(h.driver->status().state, drivers::DeviceState::streaming);
  }
  EXPECT_EQ(h.driver->exceptions(), 1u);

  // Unplug the line: the driver goes lost with a reason, backs off, reconnects and keeps counting.
  const std::size_t have = h.samples.size();
  h.emulator->disconnect_for(2000ms);  // RTU notices only by 3 timeouts of 400 ms
  ASSERT_TRUE(test::eventually([&] { return h.driver->status().state == drivers::DeviceState::lost; }, 3s));
  EXPECT_FALSE(h.driver->status().reason.empty());
  ASSERT_TRUE(test::eventually([&] { return h.driver->status().counters.reconnects >= 1; }, 8s));
  ASSERT_TRUE(h.wait_samples(have + 20));
  EXPECT_EQ(h.driver->status().state, drivers::DeviceState::streaming);
  bool gap_flagged = false;
  for (std::size_t i = have; i < h.samples.size(); ++i) gap_flagged |= (h.samples[i].flags & sample_after_gap) != 0;
  EXPECT_TRUE(gap_flagged);
  h.expect_matches_served();
}

TEST_P(MicrometerTransport, ReadsTheVirtualMachineToolsRunout) {
  simulators::machine::RunoutSpec spec;
  spec.rpm = 60.0;
  spec.samples_per_rev = 100;
  const simulators::machine::Machine machine(simulators::emulators::spindle_demo_machine_config());
  const auto motion = simulators::emulators::make_runout_motion(machine, spec);
  Harness h(GetParam(), simulators::emulators::runout_motion_source(motion));
  h.driver->start();
  ASSERT_TRUE(h.wait_samples(80));
  h.expect_matches_served();
  // Every reading is one of the model's run-out samples, as the amplifier's 10 nm counts show it.
  const drivers::modbus::RegisterMap map;
  std::vector<double> model;
  double lo = 1, hi = -1;
  // The emulator's record is endless (its time from its start): the model's first 30 s cover this test.
  simulators::machine::RunoutSpec first = spec;
  first.revolutions = 30;
  for (const auto& m : machine.runout_revolution(first)) {
    model.push_back(
        drivers::modbus::decode_registers(map, drivers::modbus::encode_registers(map, m.displacement_m)).value_m);
    lo = std::min(lo, m.displacement_m);
    hi = std::max(hi, m.displacement_m);
  }
  for (const Sample& s : h.samples) {
    EXPECT_NE(std::find(model.begin(), model.end(), s.value[0]), model.end()) << s.value[0];
  }
  EXPECT_GT(hi - lo, 0.02e-6);  // the demo spindle's lean relative to the plate is visible
}

INSTANTIATE_TEST_SUITE_P(Modbus, MicrometerTransport, ::testing::Values(false, true),
                         [](const auto& p) { return p.param ? std::string("Rtu") : std::string("Tcp"); });

TEST(MicrometerDriver, ReportsLostWhenNothingListensAndBacksOff) {
  auto table = parse_toml("transport = \"tcp\"\nport = 1\nreconnect_min_ms = 20\nreconnect_max_ms = 40\n", "t.toml");
  TableReader reader(table, "t.toml", "device[0]");
  drivers::micrometer::MicrometerDriver d("mic", drivers::micrometer::parse_micrometer_config(reader), 16);
  d.start();
  ASSERT_TRUE(test::eventually([&] { return d.status().state == drivers::DeviceState::lost; }, 3s));
  EXPECT_NE(d.status().reason.find("127.0.0.1:1"), std::string::npos) << d.status().reason;
  d.stop();
  EXPECT_EQ(d.status().state, drivers::DeviceState::stopped);
}

TEST(MicrometerDriver, RegistryCreatesItFromADeviceTable) {
  drivers::DriverRegistry registry;
  drivers::micrometer::register_micrometer_driver(registry);
  auto table = parse_toml("transport = \"rtu\"\ndevice = \"/dev/null\"\nbaud = 9600\nparity = \"N\"\n", "t.toml");
  TableReader reader(table, "t.toml", "device[0]");
  auto d = registry.create({"mic", "micrometer-modbus", {}, reader});
  ASSERT_NE(d, nullptr);
  reader.reject_unknown_keys();
  ASSERT_EQ(d->channels().size(), 1u);
  EXPECT_EQ(d->channels()[0].unit, "m");
  auto bad = parse_toml("transport = \"rtu\"\n", "t.toml");
  TableReader bad_reader(bad, "t.toml", "device[0]");
  EXPECT_THROW(registry.create({"mic", "micrometer-modbus", {}, bad_reader}), ConfigError);  // no device
}

// ---- Buffered mode: the amplifier's sample ring, read over real libmodbus TCP and RTU ----

namespace {

constexpr double ring_rate_hz = 10000.0;

// Sample k of the emulator reads k counts (10 nm each): the driver's value tells which sample it is.
simulators::emulators::MicrometerSource numbered_source() {
  return [](double t_s) { return simulators::emulators::MicrometerPoint{std::round(t_s * ring_rate_hz) * 1e-8}; };
}

struct BufferedHarness {
  // The emulated amplifier samples at emulator_rate_hz; the device table says configured_rate_hz.
  BufferedHarness(bool rtu, std::uint32_t ring_samples, std::uint32_t counter_start, const std::string& extra_keys,
                  double emulator_rate_hz = ring_rate_hz, double configured_rate_hz = ring_rate_hz) {
    MicrometerEmulator::Options o;
    o.source = numbered_source();
    drivers::modbus::SampleRingMap ring;
    ring.sample_rate_hz = emulator_rate_hz;
    ring.ring_samples = ring_samples;
    o.ring = ring;
    o.ring_counter_start = counter_start;
    ring_samples_ = ring_samples;
    emulator = std::make_unique<MicrometerEmulator>(o);
    const std::string transport = start_transport(*emulator, rtu);
    table = parse_toml(
        transport + extra_keys + "reconnect_min_ms = 50\nreconnect_max_ms = 200\n[buffer]\n" +
            "counter_address = 100\nring_address = 200\nsample_rate_hz = " + std::to_string(configured_rate_hz) +
            "\nring_samples = " + std::to_string(ring_samples) + "\n",
        "test.toml");
    TableReader reader(table, "test.toml", "device[0]");
    driver = std::make_unique<drivers::micrometer::MicrometerDriver>(
        "mic", drivers::micrometer::parse_micrometer_config(reader), 1 << 17);
    reader.reject_unknown_keys();
  }
  ~BufferedHarness() {
    driver->stop();
    emulator->stop();
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
  // The emulator's sample number of a published sample (its value in counts).
  static std::int64_t number(const Sample& s) { return std::llround(s.value[0] * 1e8); }

  // Every sample number in [first, last] was published once, or counted lost with its sequence
  // number skipped; timestamps never earlier than the emulator took the sample, nor later than
  // max_late_ns (how late depends on how quickly this machine answers: see expect_steady_stamps()).
  // Every sample lost was overwritten when the driver gave it up: each run of lost samples before the
  // first published one or between two ends at the oldest sample intact at a counter read the
  // amplifier answered (count c, sample c being written: c + 1 - ring_samples), no later; a run after
  // the last published one (a poll that lost them, then failed or was the last) ends at a read's end,
  // no later than that at the last counter read. How many that is depends on how long this machine
  // held the driver up, not on a bound. (Rings read across the counter's wrap lose nothing: the slot
  // jump of a non-power-of-two ring there is not modelled.)
  void expect_consistent(std::int64_t max_late_ns) {
    ASSERT_FALSE(samples.empty());
    const std::int64_t period_ns = 100000;
    const std::uint64_t lost = driver->lost_samples();
    std::vector<std::int64_t> resumed;  // the first sample after each run of lost ones
    if (samples.front().seq > 0) resumed.push_back(number(samples.front()));
    std::uint64_t lost_seen = samples.front().seq;
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const Sample& s = samples[i];
      ASSERT_EQ(s.flags & ~std::uint32_t{sample_after_gap}, 0u) << i;
      const std::int64_t k = number(s);
      const std::int64_t taken_ns = emulator->ring_start_ns() + k * period_ns;
      EXPECT_GE(s.t_mono_ns - taken_ns, -1000) << "sample " << k << " stamped before it was taken";
      EXPECT_LE(s.t_mono_ns - taken_ns, max_late_ns) << "sample " << k;
      if (i == 0) continue;
      const Sample& p = samples[i - 1];
      const std::int64_t dk = k - number(p);
      ASSERT_GE(dk, 1) << "sample " << k << " after " << number(p);
      ASSERT_EQ(static_cast<std::int64_t>(s.seq - p.seq), dk) << "lost samples must skip sequence numbers";
      ASSERT_EQ((s.flags & sample_after_gap) != 0, dk > 1) << "sample " << k;
      lost_seen += static_cast<std::uint64_t>(dk - 1);
      if (dk > 1) resumed.push_back(k);
      ASSERT_GE(s.t_mono_ns - p.t_mono_ns, dk * period_ns / 2 - 1)
          << "a dropping anchor moves stamps by <= half a period";
    }
    ASSERT_LE(lost_seen, lost) << "samples skipped without being counted lost";
    const std::vector<std::uint64_t> counters = emulator->served_counters();
    for (const std::int64_t k : resumed) {
      EXPECT_NE(std::find(counters.begin(), counters.end(), static_cast<std::uint64_t>(k) + ring_samples_ - 1),
                counters.end())
          << "samples before " << k << " counted lost, but no counter read showed them overwritten";
    }
    if (lost > lost_seen) {
      const auto end = static_cast<std::uint64_t>(number(samples.back()) + 1) + (lost - lost_seen);
      ASSERT_FALSE(counters.empty());
      EXPECT_LE(end + ring_samples_ - 1, *std::max_element(counters.begin(), counters.end()))
          << "samples before " << end << " counted lost after the last published one, but not overwritten";
    }
  }

  // Timestamps 1/rate apart, late by little: the anchor moves only when a quicker answer comes or the
  // quickest leaves its 0.2 s window. How often that happens, and how late the quickest answer is,
  // depends on the machine: on a loaded one (answers through a pty delayed by up to a second) neither
  // holds, so only MicrometerBufferedAlone asserts this, run on its own.
  void expect_steady_stamps() {
    ASSERT_FALSE(samples.empty());
    const std::int64_t period_ns = 100000;
    std::size_t exact_spacing = 0;
    for (std::size_t i = 1; i < samples.size(); ++i) {
      const std::int64_t dk = number(samples[i]) - number(samples[i - 1]);
      if (dk == 1 && std::abs(samples[i].t_mono_ns - samples[i - 1].t_mono_ns - period_ns) <= 1) ++exact_spacing;
    }
    EXPECT_GE(static_cast<double>(exact_spacing),
              0.99 * static_cast<double>(samples.size() - 1 - driver->ring_overruns()));
    // Late by at most a poll period plus the answers' delay, here; the p99 is what the benchmark shows.
    std::vector<std::int64_t> late;
    for (const Sample& s : samples) late.push_back(s.t_mono_ns - emulator->ring_start_ns() - number(s) * period_ns);
    std::sort(late.begin(), late.end());
    EXPECT_LT(late[late.size() / 2], 2'000'000) << "median lateness of the timestamps";
    EXPECT_LT(late.back(), 20'000'000) << "latest timestamp";
  }

  toml::table table;
  std::uint32_t ring_samples_ = 0;
  std::unique_ptr<MicrometerEmulator> emulator;
  std::unique_ptr<drivers::micrometer::MicrometerDriver> driver;
  std::vector<Sample> samples;
};

struct BufferedCase {
  bool rtu;
  std::uint32_t ring_samples;
};

// Each test runs the cases that say something of it (not every combination, skipping the rest): a lap on
// both transports and both rings; the counter wrap with the 15208-slot ring (the power-of-two one runs
// alone, with timing checks); a short outage with the 16384-slot ring; a restarted run on TCP.
class MicrometerBuffered : public ::testing::TestWithParam<BufferedCase> {};
class MicrometerBufferedOddRing : public MicrometerBuffered {};
class MicrometerBufferedLongRing : public MicrometerBuffered {};
class MicrometerBufferedTcp : public MicrometerBuffered {};

std::string buffered_case_name(const ::testing::TestParamInfo<BufferedCase>& p) {
  return std::string(p.param.rtu ? "Rtu" : "Tcp") + std::to_string(p.param.ring_samples);
}

}  // namespace

// 10 kHz on the amplifier, polled every 5 ms: every sample arrives once across a wrap of the 32-bit
// counter (at 0.5 s: the first poll has that long), with a power-of-two ring and one of 15208 slots
// (whose slot sequence jumps where the counter wraps); rings of 1.5 s, so that a slow machine
// (sanitizers) does not lap them. 2^32 mod 15208 = 15184: the slots that the samples after the wrap
// take held samples 1.5 s old, as in any lap (with 15000 slots, 2296: samples 0.23 s old, which a
// driver thread held up that long on a loaded machine has rightly lost). The samples stay in the
// harness, for the timing checks.
void delivers_every_sample_across_a_counter_wrap(BufferedHarness& h) {
  h.driver->start();
  ASSERT_TRUE(h.wait_samples(6000));
  h.driver->stop();
  h.drain();
  EXPECT_EQ(h.driver->lost_samples(), 0u);
  EXPECT_EQ(h.driver->ring_overruns(), 0u);
  EXPECT_EQ(h.driver->counter_resets(), 0u);
  const auto st = h.driver->status();
  EXPECT_EQ(st.counters.bad_frames, 0u);
  EXPECT_LT(st.counters.frames, h.samples.size() / 10);  // tens of samples per request, not one
  EXPECT_EQ(h.samples.front().seq, 0u);
  EXPECT_LE(BufferedHarness::number(h.samples.front()), 5000);  // streaming before the counter wrapped...
  EXPECT_GT(BufferedHarness::number(h.samples.back()), 5100);   // ...and after
  h.expect_consistent(1'000'000'000);
}

TEST_P(MicrometerBufferedOddRing, DeliversEverySampleAt10kHzAcrossACounterWrap) {
  BufferedHarness h(GetParam().rtu, 15208, 0xffffffffu - 5000u, "poll_period_ms = 5\n");
  delivers_every_sample_across_a_counter_wrap(h);
}

// The same, checking that the stamps are 100 us apart and late by less than 2 ms (median) and 20 ms:
// what the answers' delay allows on a machine that is not loaded. Timing-sensitive: ctest runs
// MicrometerBufferedAlone.* on its own (micrometer_modbus_timing_test).
TEST(MicrometerBufferedAlone, StampsAre100usApartAndLateByLittle) {
  for (const bool rtu : {false, true}) {
    SCOPED_TRACE(rtu ? "RTU" : "TCP");
    BufferedHarness h(rtu, 16384, 0xffffffffu - 5000u, "poll_period_ms = 5\n");
    delivers_every_sample_across_a_counter_wrap(h);
    EXPECT_EQ(h.driver->status().counters.timeouts, 0u);
    h.expect_steady_stamps();
  }
}

// A request stalls (500 ms; one, since over TCP a poll's requests go out together and two stalls
// would hit the same poll): the 2048- (or 2000-) sample ring, 0.2 s, laps. The loss is counted, its
// sequence numbers skipped, the next sample flagged; streaming goes on.
TEST_P(MicrometerBuffered, CountsAndFlagsALappedRing) {
  BufferedHarness h(GetParam().rtu, GetParam().ring_samples == 4096 ? 2048 : 2000, 0,
                    "poll_period_ms = 5\nresponse_timeout_ms = 500\n");
  h.driver->start();
  ASSERT_TRUE(h.wait_samples(1000));
  h.emulator->inject(ModbusFault::stall, 1);
  const std::size_t have = h.samples.size();
  ASSERT_TRUE(h.wait_samples(have + 3000));
  EXPECT_EQ(h.driver->status().state, drivers::DeviceState::streaming) << h.driver->status().reason;
  h.driver->stop();
  h.drain();
  EXPECT_GE(h.driver->status().counters.timeouts, 1u);
  // Once (more only if this machine stalls the driver thread for 0.2 s: counted just the same).
  EXPECT_GE(h.driver->ring_overruns(), 1u);
  EXPECT_GE(h.driver->lost_samples(), 2900u);  // >= 5000 taken while the request stalled, 1999-2047 kept
  // No upper bound: a machine that holds the driver thread up for longer than the ring (0.2 s) rightly
  // loses more. expect_consistent() checks that every sample lost had been overwritten.
  // The same counts reach STATUS by name (a user sees the loss explained, not only seq_gaps). An
  // answer this machine holds up past the timeout is discarded as stale when it comes: not counted here.
  const auto own = test::driver_counters_by_name(h.driver->status());
  EXPECT_EQ(own, (std::map<std::string, std::uint64_t>{{"exceptions", h.driver->exceptions()},
                                                       {"ring_overruns", h.driver->ring_overruns()},
                                                       {"lost_samples", h.driver->lost_samples()},
                                                       {"counter_resets", 0},
                                                       {"stale_answers", own.at("stale_answers")}}));
  h.expect_consistent(1'000'000'000);
}

// The link drops for 250 ms: the driver reconnects and fetches what the amplifier took meanwhile
// from its ring (1.6 s long): reads are idempotent, so nothing is lost or flagged. Over RTU the drop is
// seen only as 3 timeouts of 60 ms in a row: 250 ms leaves room for them on a loaded machine (150 ms
// did not, 2 runs of 11 beside a load of 5).
TEST_P(MicrometerBufferedLongRing, ShortOutageLosesNothing) {
  BufferedHarness h(GetParam().rtu, 16384, 0, "poll_period_ms = 5\nresponse_timeout_ms = 60\n");
  h.driver->start();
  ASSERT_TRUE(h.wait_samples(1000));
  h.emulator->disconnect_for(250ms);
  ASSERT_TRUE(test::eventually([&] { return h.driver->status().counters.reconnects >= 1; }, 5s));
  const std::size_t have = (h.drain(), h.samples.size());
  ASSERT_TRUE(h.wait_samples(have + 3000));
  h.driver->stop();
  h.drain();
  EXPECT_EQ(h.driver->lost_samples(), 0u);
  h.expect_consistent(1'000'000'000);
  for (const Sample& s : h.samples) ASSERT_EQ(s.flags, 0u);
}

// The amplifier restarts (its counter back to 0) 20 ms before a poll: the 200 samples its ring took
// since are fetched, from sample 0 of the new run, the first flagged after_gap; none is dropped.
TEST_P(MicrometerBufferedTcp, ResumesAtTheStartOfARestartedAmplifiersRun) {
  BufferedHarness h(false, GetParam().ring_samples, 0, "poll_period_ms = 5\n");
  h.driver->start();
  ASSERT_TRUE(h.wait_samples(1000));
  h.emulator->restart_ring(20ms);
  ASSERT_TRUE(test::eventually([&] { return h.driver->counter_resets() >= 1; }, 3s));
  const std::size_t have = (h.drain(), h.samples.size());
  ASSERT_TRUE(h.wait_samples(have + 1000));
  h.driver->stop();
  h.drain();
  EXPECT_EQ(h.driver->counter_resets(), 1u);
  EXPECT_EQ(test::driver_counters_by_name(h.driver->status()).at("counter_resets"), 1u);
  std::size_t restart = 0;
  for (std::size_t i = 1; i < h.samples.size(); ++i) {
    if (BufferedHarness::number(h.samples[i]) < BufferedHarness::number(h.samples[i - 1])) restart = i;
  }
  ASSERT_GT(restart, 0u);
  EXPECT_EQ(BufferedHarness::number(h.samples[restart]), 0) << "the new run's samples before the first read";
  EXPECT_NE(h.samples[restart].flags & sample_after_gap, 0u);
  for (std::size_t i = restart + 1; i < h.samples.size(); ++i) {
    ASSERT_EQ(BufferedHarness::number(h.samples[i]), BufferedHarness::number(h.samples[i - 1]) + 1) << i;
    ASSERT_GT(h.samples[i].t_mono_ns, h.samples[i - 1].t_mono_ns);
  }
}

INSTANTIATE_TEST_SUITE_P(Modbus, MicrometerBuffered,
                         ::testing::Values(BufferedCase{false, 4096}, BufferedCase{true, 4096},
                                           BufferedCase{false, 3000}, BufferedCase{true, 3000}),
                         buffered_case_name);
INSTANTIATE_TEST_SUITE_P(Modbus, MicrometerBufferedOddRing,
                         ::testing::Values(BufferedCase{false, 3000}, BufferedCase{true, 3000}), buffered_case_name);
INSTANTIATE_TEST_SUITE_P(Modbus, MicrometerBufferedLongRing,
                         ::testing::Values(BufferedCase{false, 4096}, BufferedCase{true, 4096}), buffered_case_name);
INSTANTIATE_TEST_SUITE_P(Modbus, MicrometerBufferedTcp,
                         ::testing::Values(BufferedCase{false, 4096}, BufferedCase{false, 3000}), buffered_case_name);

// The amplifier samples at 10 kHz but the table says 2 kHz: every counter read looks like a restart.
// The device must not sit silently "streaming" with nothing published: it reports an error saying why.
TEST(MicrometerDriver, BufferedCounterFasterThanTheConfiguredRateIsAnError) {
  BufferedHarness h(false, 4096, 0, "poll_period_ms = 5\n", ring_rate_hz, 2000.0);
  drivers::micrometer::MicrometerDriver& d = *h.driver;
  d.start();
  ASSERT_TRUE(test::eventually([&] { return d.status().state == drivers::DeviceState::error; }, 3s));
  EXPECT_NE(d.status().reason.find("sample_rate_hz = 2000"), std::string::npos) << d.status().reason;
  EXPECT_GE(d.counter_resets(), 3u);
  // A network blip in between: after the reconnect the state must come back to error, not stay
  // "streaming" with nothing published.
  h.emulator->disconnect_for(100ms);
  ASSERT_TRUE(test::eventually([&] { return d.status().counters.reconnects >= 1; }, 5s));
  // After the reconnect the error comes back (at the first polls, whenever a loaded machine runs them) and
  // then holds: over 0.4 s the device is never "streaming" with nothing published (without the fix it
  // stays "streaming" from the reconnect on).
  ASSERT_TRUE(test::eventually([&] { return d.status().state == drivers::DeviceState::error; }, 5s))
      << "the error must come back after the reconnect";
  int streaming = 0;
  for (int i = 0; i < 20; ++i, std::this_thread::sleep_for(20ms)) {
    streaming += d.status().state == drivers::DeviceState::streaming ? 1 : 0;
  }
  EXPECT_LE(streaming, 1) << "the error must hold after the reconnect";
  EXPECT_EQ(d.status().state, drivers::DeviceState::error);
}

// The amplifier samples 1 % slower than the table says (9900 Hz for 10000): timestamps would drift
// early unnoticed. The driver measures the real rate over 1 s and reports an error saying so.
TEST(MicrometerDriver, BufferedCounterSlowerThanTheConfiguredRateIsAnError) {
  BufferedHarness h(false, 4096, 0, "poll_period_ms = 5\n", 9900.0, ring_rate_hz);
  drivers::micrometer::MicrometerDriver& d = *h.driver;
  d.start();
  ASSERT_TRUE(test::eventually([&] { return d.status().state == drivers::DeviceState::error; }, 5s));
  const std::string reason = d.status().reason;
  const auto at = reason.find("% slower than sample_rate_hz = 10000 (measured ");
  ASSERT_NE(at, std::string::npos) << reason;
  const double measured_hz =
      std::stod(reason.substr(at + std::string("% slower than sample_rate_hz = 10000 (measured ").size()));
  EXPECT_NEAR(measured_hz, 9900.0, 50.0)
      << reason;  // loose: the estimate rests on the quickest answers of a loaded machine
  EXPECT_EQ(d.counter_resets(), 0u);
  EXPECT_GT(d.status().counters.samples, 5000u) << "still published";
}

TEST(MicrometerDriver, BufferedConfigErrorsNameFileLineAndKey) {
  auto error = [](const std::string& text) {
    auto table = parse_toml(text, "mic.toml");
    TableReader reader(table, "mic.toml", "device[0]");
    try {
      drivers::micrometer::parse_micrometer_config(reader);
      reader.reject_unknown_keys();
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const std::string buffer =
      "[buffer]\ncounter_address = 100\nring_address = 200\nring_samples = 1000\nsample_rate_hz = 10000\n";
  EXPECT_EQ(error("port = 1502\n" + buffer), "accepted");
  // 1000 samples in 100 ms: more than half the ring per poll.
  EXPECT_NE(error("port = 1502\npoll_period_ms = 100\n" + buffer).find("mic.toml:2: device[0].poll_period_ms"),
            std::string::npos);
  EXPECT_NE(error("port = 1502\npoll_hz = 100\n" + buffer).find("mic.toml:2: device[0].poll_hz"), std::string::npos);
  EXPECT_NE(error("port = 1502\npoll_period_ms = 5\n").find("mic.toml:2: device[0].poll_period_ms"), std::string::npos);
  EXPECT_NE(error("port = 1502\n[registers]\nvalue_type = \"int16\"\n" + buffer).find("device[0].buffer"),
            std::string::npos);
  EXPECT_NE(error("port = 1502\n[buffer]\nring_address = 200\nring_samples = 10\nsample_rate_hz = 1\n")
                .find("device[0].buffer.counter_address"),
            std::string::npos);
  EXPECT_NE(error("port = 1502\n" + buffer + "ring_size = 4\n").find("mic.toml:7: device[0].buffer.ring_size"),
            std::string::npos);
}

// One set of reconnect keys for every loop-driven driver, read by the skeleton (drivers::read_reconnect):
// the micrometer's and profilometer's old names still work, each said as a deprecation; a table that
// gives a key under both names, or a ceiling below the first wait, is refused naming file, line and key.
TEST(MicrometerDriver, ReconnectKeysAreTheSkeletonsAndTheOldNamesAreDeprecated) {
  const auto parse = [](const std::string& keys) {
    auto table = parse_toml("port = 1502\n" + keys, "mic.toml");
    TableReader reader(table, "mic.toml", "device[0]");
    auto c = drivers::micrometer::parse_micrometer_config(reader);
    reader.reject_unknown_keys();
    return c;
  };
  const auto error = [&](const std::string& keys) {
    try {
      parse(keys);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const auto defaults = parse("");
  EXPECT_DOUBLE_EQ(defaults.reconnect.backoff.min_s, 0.1);
  EXPECT_DOUBLE_EQ(defaults.reconnect.backoff.max_s, 5.0);
  EXPECT_TRUE(defaults.reconnect.deprecated.empty());
  const auto now = parse("reconnect_min_ms = 20\nreconnect_max_ms = 40\n");
  EXPECT_DOUBLE_EQ(now.reconnect.backoff.min_s, 0.02);
  EXPECT_DOUBLE_EQ(now.reconnect.backoff.max_s, 0.04);
  EXPECT_TRUE(now.reconnect.deprecated.empty());
  const auto old = parse("backoff_initial_ms = 20\nbackoff_max_ms = 40\n");
  EXPECT_DOUBLE_EQ(old.reconnect.backoff.min_s, 0.02);
  EXPECT_DOUBLE_EQ(old.reconnect.backoff.max_s, 0.04);
  ASSERT_EQ(old.reconnect.deprecated.size(), 2u);
  EXPECT_NE(old.reconnect.deprecated[0].find("device[0].backoff_initial_ms is deprecated: write reconnect_min_ms"),
            std::string::npos)
      << old.reconnect.deprecated[0];
  EXPECT_NE(old.reconnect.deprecated[1].find("backoff_max_ms is deprecated: write reconnect_max_ms"), std::string::npos);
  // The skeleton posts each as a warning event, which the daemon logs.
  drivers::micrometer::MicrometerDriver driver("mic", old, 16);
  const auto events = driver.take_events();
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].event, "deprecated_key");
  EXPECT_TRUE(events[0].warning);
  EXPECT_EQ(events[0].reason, old.reconnect.deprecated[0]);
  // And STATUS lists them among the device's warnings for as long as it runs.
  EXPECT_EQ(driver.status().warnings, old.reconnect.deprecated);
  EXPECT_NE(error("reconnect_min_ms = 20\nbackoff_initial_ms = 30\n")
                .find("mic.toml:3: device[0].backoff_initial_ms: backoff_initial_ms is the old name of reconnect_min_ms"),
            std::string::npos)
      << error("reconnect_min_ms = 20\nbackoff_initial_ms = 30\n");
  EXPECT_NE(error("reconnect_min_ms = 20\nreconnect_max_ms = 10\n")
                .find("mic.toml:3: device[0].reconnect_max_ms: must not be less than reconnect_min_ms (20 ms)"),
            std::string::npos)
      << error("reconnect_min_ms = 20\nreconnect_max_ms = 10\n");
  EXPECT_NE(error("reconnect_min_ms = 0\n").find("device[0].reconnect_min_ms"), std::string::npos);
}

// An answer that comes after the driver gave up on it (700 ms, timeout 400 ms) is never taken for the
// next request's: RTU has no transaction id, so the driver first brings the line back in step; TCP's
// transaction id does it. Every published reading is one the emulator answered in time, in order.
TEST_P(MicrometerTransport, ALateAnswerIsNeverTakenForTheNextRequest) {
  Harness h(GetParam(), counting_source());
  h.driver->start();
  ASSERT_TRUE(h.wait_samples(10));
  const auto before = h.driver->status().counters;
  h.emulator->inject(ModbusFault::late, 2);
  const std::size_t have = h.samples.size();
  ASSERT_TRUE(h.wait_samples(have + 30));
  EXPECT_GE(h.driver->status().counters.timeouts, before.timeouts + 2);
  if (GetParam()) {
    EXPECT_GE(test::driver_counters_by_name(h.driver->status()).at("stale_answers"), 1u)
        << "the late answers were discarded, not merely missed";
  }
  h.expect_matches_served();
}

// RTU: an answer so late that the Report Server ID probe sent after the timeout (400 ms) hears
// nothing for its whole timeout either (the amplifier is still busy with the late request): it comes
// while a later read waits, with the same function code and byte count. 1 s: while the marker read
// (of a count no unanswered read asked for) waits; 1.5 s: after the marker timed out too, the link
// was declared lost (3 failures) and the serial line reopened, which must not count as in step. The
// late answer is discarded and counted, never published as a reading. Deterministic: it lands
// 150-250 ms inside that read's window, without load.
class MicrometerRtuVeryLate : public ::testing::TestWithParam<int> {};

TEST_P(MicrometerRtuVeryLate, AnAnswerLaterThanTheProbesTimeoutIsNeverTaken) {
  Harness h(true, counting_source(), true, std::chrono::milliseconds(GetParam()));
  h.driver->start();
  ASSERT_TRUE(h.wait_samples(10));
  h.emulator->inject(ModbusFault::late, 1);
  const std::size_t have = h.samples.size();
  ASSERT_TRUE(h.wait_samples(have + 30));
  EXPECT_GE(test::driver_counters_by_name(h.driver->status()).at("stale_answers"), 1u)
      << "the late answer was discarded";
  h.expect_matches_served();
}

INSTANTIATE_TEST_SUITE_P(Modbus, MicrometerRtuVeryLate, ::testing::Values(1000, 1500),
                         [](const auto& p) { return std::to_string(p.param) + "ms"; });

// A server that ignores Report Server ID (no exception answer, against the standard): one timeout
// costs the read and the silent probe, two failures of the three that declare the link lost; the next
// read is answered, so the server is not probed again and the link never drops.
TEST(MicrometerRtu, AServerIgnoringTheProbeIsReadOnWithoutIt) {
  Harness h(true, simulators::emulators::runout_source(120.0), false);
  h.driver->start();
  ASSERT_TRUE(h.wait_samples(10));
  for (int round = 0; round < 2; ++round) {
    h.emulator->inject(ModbusFault::stall, 1);
    const std::size_t have = h.samples.size();
    ASSERT_TRUE(h.wait_samples(have + 20));
  }
  const auto st = h.driver->status();
  EXPECT_EQ(st.counters.reconnects, 0u);
  EXPECT_EQ(st.state, drivers::DeviceState::streaming);
  EXPECT_GE(st.counters.timeouts, 3u) << "the first stall and its silent probe, then the second stall alone";
  h.expect_matches_served();
}

// Over RTU libmodbus blocks for each read: a whole response timeout (here 1 s) when the amplifier does
// not answer, again for the probe after it. The driver is on the skeleton all the same, on the loop it
// shares with the other devices, and only the line's thread takes that wait (drivers/modbus/rtu_line.hpp):
// another device's timer on the loop, every 5 ms, is never held up by the line.
TEST(MicrometerRtu, AStalledReadNeverHoldsUpTheSharedLoop) {
  MicrometerEmulator::Options o;
  o.source = simulators::emulators::runout_source(120.0);
  MicrometerEmulator emulator(o);
  auto table = parse_toml(start_transport(emulator, true) +
                              "poll_hz = 50\nresponse_timeout_ms = 1000\nlost_after_failures = 3\n"
                              "[registers]\nvalue_type = \"int32\"\n",
                          "test.toml");
  TableReader reader(table, "test.toml", "device[0]");
  drivers::micrometer::MicrometerDriver driver("mic", drivers::micrometer::parse_micrometer_config(reader), 1 << 14);
  EXPECT_TRUE(driver.loop_driven());
  drivers::IoLoop loop;
  loop.start("test-io");
  std::int64_t due_ns = 0, worst_late_ns = 0;  // the loop thread's
  int fired = 0;
  drivers::IoLoop::Id timer = 0;
  loop.call([&] {
    timer = loop.add_timer([&] {
      worst_late_ns = std::max(worst_late_ns, mono_now_ns() - due_ns);
      ++fired;
      due_ns = mono_now_ns() + 5'000'000;
      loop.arm(timer, due_ns);
    });
    due_ns = mono_now_ns() + 5'000'000;
    loop.arm(timer, due_ns);
  });
  driver.start(&loop);
  std::size_t samples = 0;
  const auto samples_reach = [&](std::size_t n) {
    return test::eventually([&] {
      Sample s;
      while (driver.ring().try_pop(s)) ++samples;
      return samples >= n;
    });
  };
  ASSERT_TRUE(samples_reach(10));
  emulator.inject(ModbusFault::stall, 1);
  ASSERT_TRUE(test::eventually([&] { return driver.status().counters.timeouts >= 1; }, 10s));
  ASSERT_TRUE(samples_reach(samples + 10));
  driver.stop();
  int fired_total = 0;
  std::int64_t worst = 0;
  loop.call([&] {
    loop.remove_timer(timer);
    fired_total = fired;
    worst = worst_late_ns;
  });
  loop.stop();
  emulator.stop();
  EXPECT_LT(worst, 300'000'000) << "the loop waited for the line (a read timed out after 1 s meanwhile)";
  EXPECT_GT(fired_total, 100);
}

namespace {

// A buffered amplifier on Modbus TCP written out by hand (the emulator's libmodbus cannot say how
// requests arrive): counter at 100-101, 16384 slots of 3 registers from 200, sample k holding k counts
// (10 nm), 10 kHz. It counts the requests that came in one read of the socket, and can answer only
// the first of them (a device that takes one request at a time and drops the rest).
class HandWrittenAmplifier {
 public:
  explicit HandWrittenAmplifier(bool first_only) : first_only_(first_only) {
    listen_fd_ = test::listen_on_loopback(port_);
    t0_ = std::chrono::steady_clock::now();
    server_ = std::thread([this] { serve(); });
  }
  ~HandWrittenAmplifier() {
    stop_ = true;
    server_.join();
    ::close(listen_fd_);
  }
  [[nodiscard]] int port() const noexcept { return port_; }
  [[nodiscard]] std::size_t most_requests_in_one_read() const noexcept { return most_.load(); }

 private:
  static constexpr std::uint32_t slots = 16384;
  void serve() {
    int client = -1;
    std::vector<std::uint8_t> in;
    while (!stop_) {
      pollfd p{client >= 0 ? client : listen_fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      if (client < 0) {
        client = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
        continue;
      }
      std::uint8_t buf[1024];
      const ssize_t n = ::recv(client, buf, sizeof buf, 0);
      if (n <= 0) {
        ::close(client);
        client = -1;
        in.clear();
        continue;
      }
      in.insert(in.end(), buf, buf + n);
      const std::size_t requests = in.size() / 12;
      most_ = std::max(most_.load(), requests);
      std::vector<std::uint8_t> out;
      for (std::size_t r = 0; r < requests && !(first_only_ && r > 0); ++r) answer(&in[r * 12], out);
      in.erase(in.begin(), in.begin() + static_cast<std::ptrdiff_t>(requests * 12));
      if (!out.empty()) (void)!::send(client, out.data(), out.size(), MSG_NOSIGNAL);
    }
    if (client >= 0) ::close(client);
  }
  // One read of input registers (the driver asks nothing else here).
  void answer(const std::uint8_t* q, std::vector<std::uint8_t>& out) const {
    const auto taken = static_cast<std::uint64_t>(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count() * ring_rate_hz);
    const int address = (q[8] << 8) | q[9];
    const int count = (q[10] << 8) | q[11];
    out.insert(out.end(), {q[0], q[1], 0, 0, static_cast<std::uint8_t>((3 + 2 * count) >> 8),
                           static_cast<std::uint8_t>(3 + 2 * count), q[6], q[7], static_cast<std::uint8_t>(2 * count)});
    for (int a = address; a < address + count; ++a) {
      std::uint16_t v = 0;
      if (a == 100 || a == 101) {
        v = static_cast<std::uint16_t>(a == 100 ? taken >> 16 : taken);
      } else if (a >= 200) {
        // The newest sample in the slot (none yet: 0).
        const std::uint64_t slot = static_cast<std::uint64_t>(a - 200) / 3;
        const std::uint64_t k = taken > slot ? slot + (taken - 1 - slot) / slots * slots : 0;
        const int field = (a - 200) % 3;
        v = field == 0 ? static_cast<std::uint16_t>(k >> 16) : field == 1 ? static_cast<std::uint16_t>(k) : 0;
      }
      out.push_back(static_cast<std::uint8_t>(v >> 8));
      out.push_back(static_cast<std::uint8_t>(v & 0xff));
    }
  }

  bool first_only_;
  int listen_fd_ = -1;
  int port_ = 0;
  std::chrono::steady_clock::time_point t0_;
  std::atomic<bool> stop_{false};
  std::atomic<std::size_t> most_{0};
  std::thread server_;
};

// Every sample from the first, once, in order (the value says which one it is).
void expect_every_sample_once(const std::vector<Sample>& samples) {
  ASSERT_FALSE(samples.empty());
  for (std::size_t i = 1; i < samples.size(); ++i) {
    ASSERT_EQ(std::llround(samples[i].value[0] * 1e8), std::llround(samples[i - 1].value[0] * 1e8) + 1) << i;
    ASSERT_EQ(samples[i].seq, samples[i - 1].seq + 1);
    ASSERT_GT(samples[i].t_mono_ns, samples[i - 1].t_mono_ns);
  }
}

// A buffered driver for `amplifier` (10 kHz, 5 ms polls, 250 ms response timeout: a loaded machine holds
// up an answer by 100 ms now and then, and the tests count timeouts), not started.
std::unique_ptr<drivers::micrometer::MicrometerDriver> buffered_driver(const HandWrittenAmplifier& amplifier) {
  const toml::table table = parse_toml(
      "transport = \"tcp\"\nhost = \"127.0.0.1\"\nport = " + std::to_string(amplifier.port()) +
          "\npoll_period_ms = 5\nresponse_timeout_ms = 250\n[buffer]\ncounter_address = 100\nring_address = 200\n"
          "sample_rate_hz = 10000\nring_samples = 16384\n",
      "test.toml");
  TableReader reader(table, "test.toml", "device[0]");
  return std::make_unique<drivers::micrometer::MicrometerDriver>(
      "mic", drivers::micrometer::parse_micrometer_config(reader), 1 << 17);
}

// A buffered driver against `amplifier` until it has published 3000 samples; every one of them, once,
// in order. Returns the stopped driver.
std::unique_ptr<drivers::micrometer::MicrometerDriver> stream_from(const HandWrittenAmplifier& amplifier) {
  auto d = buffered_driver(amplifier);
  d->start();
  std::vector<Sample> samples;
  Sample s;
  (void)test::eventually([&] {
    while (d->ring().try_pop(s)) samples.push_back(s);
    return samples.size() >= 3000;
  });
  d->stop();
  while (d->ring().try_pop(s)) samples.push_back(s);
  EXPECT_GE(samples.size(), 3000u);
  expect_every_sample_once(samples);
  return d;
}

}  // namespace

// Over TCP a buffered poll sends its counter read and the reads of the ring's new part in one write
// (one round trip a poll): the amplifier sees them together, and every sample arrives once.
TEST(MicrometerBufferedPipelined, CounterAndRingReadsGoOutInOneWrite) {
  HandWrittenAmplifier amplifier(false);
  const auto d = stream_from(amplifier);
  EXPECT_GE(amplifier.most_requests_in_one_read(), 2u);
  EXPECT_EQ(d->status().counters.timeouts, 0u);
  EXPECT_EQ(test::driver_counters_by_name(d->status()).at("stale_answers"), 0u);
}

// An amplifier that answers only the first of the requests that come together: two polls time out
// (one lost answer is not enough to tell), then the driver asks one request at a time and loses nothing.
TEST(MicrometerBufferedPipelined, AnAmplifierTakingOneRequestAtATimeIsAskedSo) {
  HandWrittenAmplifier amplifier(true);
  const auto d = stream_from(amplifier);
  const auto st = d->status();
  EXPECT_GE(st.counters.timeouts, 2u);
  EXPECT_LE(st.counters.timeouts, 3u) << "a pipelined ask that arrives split in two reads is answered in full";
  EXPECT_EQ(st.counters.reconnects, 0u);
  EXPECT_EQ(d->lost_samples(), 0u);
}

// On the I/O loop it shares, with another device keeping the loop passing by every 200 us (well inside
// the 700 us read period, so a read at its passes never waits for a rest to end), a buffered poll's
// answers are read when they come, in passes of their own: the poll's newest sample does not wait for
// the other device's next pass (issue 45, the p99 below 1 ms). Every sample once all the same.
TEST(MicrometerBufferedPipelined, TheAnswersAreReadWhenTheyComeWhileAnotherDeviceKeepsTheLoopBusy) {
  HandWrittenAmplifier amplifier(false);
  const auto driver = buffered_driver(amplifier);
  drivers::micrometer::MicrometerDriver& d = *driver;
  drivers::IoLoop loop;
  loop.start("test-io");
  test::OtherDeviceOnTheLoop other(loop, d, 200'000);
  d.start(&loop);
  std::vector<Sample> samples;
  Sample s;
  (void)test::eventually([&] {
    while (d.ring().try_pop(s)) samples.push_back(s);
    return samples.size() >= 3000;
  });
  d.stop();
  const test::OtherDeviceOnTheLoop::Passes passes = other.remove();
  loop.stop();
  while (d.ring().try_pop(s)) samples.push_back(s);
  EXPECT_GE(samples.size(), 3000u);
  expect_every_sample_once(samples);
  // About 60 polls. Read at the other device's passes, all but the first (before the other device was
  // seen) would come in one of them.
  EXPECT_GE(passes.own, 10) << "polls published in the other device's passes: " << passes.others;
  EXPECT_EQ(d.status().counters.timeouts, 0u);
}
