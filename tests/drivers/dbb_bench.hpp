#pragma once
// The DBB driver against the DBB emulator through the real CAN transport (can_frame records over
// socketpair(AF_UNIX, SOCK_SEQPACKET)), shared by the driver's tests: three encoders, a circle, and
// the check that every cycle the emulator put on the bus became exactly one sample, equal to it.

#include <gtest/gtest.h>
#include <sys/socket.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "driver_samples_support.hpp"
#include "drivers/dbb/dbb_driver.hpp"
#include "simulators/emulators/dbb_emulator.hpp"
#include "test_support.hpp"

namespace guideway::test {

inline std::vector<drivers::dbb::EncoderScale> three_encoders() {
  std::vector<drivers::dbb::EncoderScale> e(3);
  e[0] = {"bar_length", 1, 1e-7, +1, 0, 0.100};
  e[1] = {"x", 2, 1e-7, +1, 0, 0.0};
  e[2] = {"y", 3, 5e-8, -1, 1000, 0.0};
  return e;
}

// The emulator's nodes as three_encoders() describes them: CANopen nodes that boot pre-operational.
inline simulators::emulators::DbbEmulatorSettings emulator_settings(bool produce_sync, double rate_hz) {
  simulators::emulators::DbbEmulatorSettings s;
  s.encoders = three_encoders();
  s.produce_sync = produce_sync;
  s.sync_rate_hz = rate_hz;
  return s;
}

inline simulators::emulators::DbbSource circle_source() {
  return simulators::emulators::ideal_circle_source(0.1, 2000.0 / 60e3, +1, 3e-6);
}

// Adjust the settings a Bench gives the driver or the emulator (CANopen options, faults present from
// power-on).
using TuneDriver = std::function<void(drivers::dbb::DbbSettings&)>;
using TuneEmulator = std::function<void(simulators::emulators::DbbEmulatorSettings&)>;

inline simulators::emulators::DbbEmulatorSettings tuned(simulators::emulators::DbbEmulatorSettings s,
                                                        const TuneEmulator& tune) {
  if (tune) tune(s);
  return s;
}

// A driver and the emulator, joined by a socketpair per connection; the driver is served by `loop`
// (shared with other devices) or by a loop of its own.
struct Bench {
  explicit Bench(bool produces_sync, double rate_hz = 200.0, std::int64_t timeout_ms = 150,
                 simulators::emulators::DbbSource source = circle_source(),
                 std::int64_t read_period_us = drivers::dbb::default_read_period_us, const TuneDriver& tune_driver = {},
                 const TuneEmulator& tune_emulator = {}, drivers::IoLoop* loop = nullptr)
      : emu(tuned(emulator_settings(!produces_sync, rate_hz), tune_emulator), std::move(source)),
        driver_produces_sync(produces_sync),
        sync_period_ns(static_cast<std::int64_t>(1e9 / rate_hz)) {
    drivers::dbb::DbbSettings s;
    s.produce_sync = produces_sync;
    s.sync_rate_hz = rate_hz;
    s.read_period_us = read_period_us;
    s.timeout_ms = timeout_ms;
    s.reconnect.backoff = Backoff::between(std::chrono::milliseconds(10), std::chrono::milliseconds(100));
    s.encoders = three_encoders();
    if (tune_driver) tune_driver(s);
    emu.start();
    driver = std::make_unique<drivers::dbb::DbbDriver>("dbb", 1 << 14, s, [this](std::string& err) {
      int sv[2];
      if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) < 0) {
        err = "socketpair failed";
        return drivers::can::CanSocket{};
      }
      ++connects;
      emu.attach(drivers::can::CanSocket(sv[1]));
      return drivers::can::CanSocket(sv[0]);
    });
    driver->start(loop);  // a loop shared with other devices, or one of its own
  }
  ~Bench() {
    driver->stop();
    emu.stop();
  }
  void drain() { drain_samples(*driver, samples); }
  bool wait_samples(std::size_t n, std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    return test::wait_samples(*driver, samples, n, timeout);
  }
  // Stops both ends, then checks every cycle the emulator sent against the samples, in order. Every cycle
  // is exactly one sample, equal to what was sent (a channel not sent holds the previous sample's value),
  // except an answer the emulator logged as late (a loaded machine held it up until the driver's next SYNC
  // was there): on the bus it may be partly after that SYNC, and the driver then makes it a sample of
  // what came before the SYNC (the rest held), or, all of it after, no sample of its own (the next
  // answer replaces it). Which of the two each late answer became is not known, and positions of a
  // slow machine repeat, so the check searches for an assignment of samples to cycles that explains
  // every sample (a set of reachable sample indices per cycle), its values and its time (a sample
  // given another cycle's time is no cycle's). One such assignment is kept in `cycle_of` (the index
  // in `sent` of each sample's cycle). Driving the SYNC, a hole of two periods or more in the samples
  // must be flagged on the sample after it.
  void stop_and_check_all(std::size_t partial_expected_at_least = 0) {
    // The emulator goes first: the driver then reads everything still queued, publishes what it holds
    // when it sees the end of the connection, and only then reports the loss.
    const int connects_before = connects.load();
    emu.stop();
    const auto log = emu.log();
    sent.clear();
    std::size_t late = 0;
    for (const auto& c : log) {
      if (c.sent_mask != 0) sent.push_back(c);
      late += c.late;
    }
    EXPECT_TRUE(test::eventually([&] {
      return connects.load() > connects_before || driver->status().state != drivers::DeviceState::streaming;
    })) << "the driver did not see the emulator go";
    driver->stop();
    drain();
    ASSERT_LE(samples.size(), sent.size()) << "a cycle put on the bus became more than one sample";
    ASSERT_GE(samples.size() + late, sent.size()) << "a cycle put on the bus (and not late) became no sample";
    const auto near = [](double a, double b, std::size_t k) {
      return std::abs(a - b) <= three_encoders()[k].resolution_m * 0.51;
    };
    const auto held = [&](std::size_t j, std::size_t k) {
      const double before = j > 0 ? samples[j - 1].value[k] : NAN;
      const double v = samples[j].value[k];
      return std::isnan(before) ? std::isnan(v) : near(v, before, k);
    };
    // Whether samples[j] can be sent[i]'s; `why` says why not.
    const auto is_sample_of = [&](std::size_t i, std::size_t j, std::string& why) {
      const Sample& s = samples[j];
      const bool complete = sent[i].sent_mask == 0b111;
      if (s.value_count != 3) return why = "value_count " + std::to_string(s.value_count), false;
      if (j > 0 && s.t_mono_ns < samples[j - 1].t_mono_ns) return why = "time goes backwards", false;
      if (!sent[i].late && ((s.flags & sample_partial) != 0) == complete) return why = "partial flag wrong", false;
      // Its time is its cycle's SYNC as received: the emulator's own, or ours as it echoed it, in the batch
      // of the answers it computed at the cycle's t_mono_ns, so after that and before the next. That is
      // the kernel's real-time stamp put on the monotonic clock by an offset read to within a
      // few microseconds (realtime_minus_mono_ns: half its readings' width, at most 5 us when they are
      // tight): a stamp 24 ns after the emulator's clock read came out 24 ns before it.
      constexpr std::int64_t conversion_slack_ns = 10'000;
      if (s.t_mono_ns < sent[i].t_mono_ns - conversion_slack_ns ||
          (i + 1 < sent.size() && s.t_mono_ns > sent[i + 1].t_mono_ns + conversion_slack_ns))
        return why = "time " + std::to_string(s.t_mono_ns) + " is not this cycle's (sent at " +
                     std::to_string(sent[i].t_mono_ns) +
                     (i + 1 < sent.size() ? ", the next at " + std::to_string(sent[i + 1].t_mono_ns) : std::string()) + ")",
                     false;
      for (std::size_t k = 0; k < 3; ++k) {
        const bool was_sent = (sent[i].sent_mask & (1u << k)) != 0;
        const bool exact = was_sent && near(s.value[k], sent[i].truth_m[k], k);
        const bool ok = sent[i].late ? exact || held(j, k) : was_sent ? exact : held(j, k);
        if (!ok) {
          why = "channel " + std::to_string(k) + " is " + std::to_string(s.value[k]) +
                (was_sent ? ", sent " + std::to_string(sent[i].truth_m[k]) : std::string(", not sent, not held"));
          return false;
        }
      }
      return true;
    };
    // Samples j-3..j+3 beside the cycles sent around their times: what a failure below is about.
    const auto around = [&](std::size_t j) {
      std::string out = "\n  samples (t_mono_ns flags values):";
      const std::size_t a = j > 3 ? j - 3 : 0, b = std::min(samples.size(), j + 4);
      for (std::size_t k = a; k < b; ++k) {
        out += "\n   " + std::string(k == j ? "> " : "  ") + std::to_string(k) + ": " +
               std::to_string(samples[k].t_mono_ns) + " " + std::to_string(samples[k].flags);
        for (std::size_t c = 0; c < 3; ++c) out += " " + std::to_string(samples[k].value[c]);
      }
      if (a >= b) return out;
      const std::int64_t from = samples[a].t_mono_ns - 2 * sync_period_ns, to = samples[b - 1].t_mono_ns + 2 * sync_period_ns;
      out += "\n  cycles sent (t_mono_ns mask late truth):";
      for (std::size_t i = 0; i < sent.size(); ++i) {
        if (sent[i].t_mono_ns < from || sent[i].t_mono_ns > to) continue;
        out += "\n     " + std::to_string(i) + ": " + std::to_string(sent[i].t_mono_ns) + " " +
               std::to_string(sent[i].sent_mask) + (sent[i].late ? " late" : "");
        for (const double v : sent[i].truth_m) out += " " + std::to_string(v);
      }
      return out;
    };
    std::vector<std::size_t> reach{0};  // sample indices at which cycle i can start
    std::vector<std::vector<std::size_t>> reached;  // reach before each cycle
    for (std::size_t i = 0; i < sent.size(); ++i) {
      reached.push_back(reach);
      std::vector<std::size_t> next;
      std::string why;
      for (const std::size_t j : reach) {
        if (sent[i].late) next.push_back(j);  // no sample of its own
        std::string w;
        if (j < samples.size() && is_sample_of(i, j, w))
          next.push_back(j + 1);
        else if (why.empty())
          why = j < samples.size() ? "sample " + std::to_string(j) + ": " + w : "no sample left";
      }
      std::sort(next.begin(), next.end());
      next.erase(std::unique(next.begin(), next.end()), next.end());
      ASSERT_FALSE(next.empty()) << "sent cycle " << i << (sent[i].late ? " (late)" : "")
                                 << " matches no sample: " << why << around(reach.empty() ? 0 : reach.front());
      reach = std::move(next);
    }
    ASSERT_TRUE(std::find(reach.begin(), reach.end(), samples.size()) != reach.end())
        << "samples left over (" << samples.size() - reach.back() << "): a cycle became more than one sample"
        << around(reach.back());
    // One assignment, walked back from the end: a late cycle takes no sample where that explains the rest.
    cycle_of.assign(samples.size(), 0);
    std::size_t j = samples.size();
    for (std::size_t i = sent.size(); i-- > 0;) {
      const auto& before = reached[i];
      std::string why;
      if (sent[i].late && std::find(before.begin(), before.end(), j) != before.end()) continue;
      ASSERT_TRUE(j > 0 && std::find(before.begin(), before.end(), j - 1) != before.end() && is_sample_of(i, j - 1, why))
          << "cycle " << i;
      cycle_of[--j] = i;
    }
    for (std::size_t k = 1; driver_produces_sync && k < samples.size(); ++k) {
      const std::int64_t dt = samples[k].t_mono_ns - samples[k - 1].t_mono_ns;
      EXPECT_GT(dt, 0) << "sample " << k << ": two cycles, one time";
      // A hole (a SYNC slot missed, not sent or not answered) is flagged on the sample after it.
      if (dt >= 2 * sync_period_ns) {
        EXPECT_TRUE(samples[k].flags & sample_after_gap)
            << "a hole of " << static_cast<double>(dt) / 1e6 << " ms before sample " << k << " is not flagged"
            << around(k);
      }
    }
    for (std::size_t k = 0; k < samples.size(); ++k) EXPECT_EQ(samples[k].seq, k);
    const auto partial =
        std::count_if(samples.begin(), samples.end(), [](const Sample& s) { return (s.flags & sample_partial) != 0; });
    EXPECT_GE(static_cast<std::size_t>(partial), partial_expected_at_least);
    ::testing::Test::RecordProperty("late_answers", std::to_string(late));
  }

  simulators::emulators::DbbEmulator emu;
  bool driver_produces_sync;
  std::int64_t sync_period_ns;
  std::unique_ptr<drivers::dbb::DbbDriver> driver;
  std::atomic<int> connects{0};
  std::vector<Sample> samples;
  // stop_and_check_all(): the cycles the emulator put on the bus, and the one each sample is.
  std::vector<simulators::emulators::DbbSentCycle> sent;
  std::vector<std::size_t> cycle_of;
};

}  // namespace guideway::test
