// The sample ring's pure parts: config parsing, the read plan, the block decoder, which samples a
// lapping ring still holds, the counter unwrap and the time anchor. Property tests run against an
// independent model of the amplifier written here (a slot array that records which sample owns it).
#include "drivers/modbus/sample_ring.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/sample.hpp"

using namespace guideway;
using namespace guideway::drivers::modbus;

namespace {

SampleRingMap ring_from(const std::string& toml_text) {
  static toml::table table;  // TableReader keeps a pointer
  table = parse_toml(toml_text, "test.toml");
  TableReader reader(table, "test.toml", "device[0].buffer");
  SampleRingMap m = parse_sample_ring(reader);
  reader.reject_unknown_keys();
  return m;
}

std::string config_error(const std::string& toml_text) {
  try {
    ring_from(toml_text);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "accepted";
}

const std::string minimal = "counter_address = 100\nring_address = 200\nring_samples = 1000\nsample_rate_hz = 5000\n";

// A random valid map: any value type, with or without status, small rings of any length.
SampleRingMap random_map(std::mt19937_64& rng) {
  const ValueType types[] = {ValueType::int16, ValueType::uint16, ValueType::int32, ValueType::uint32,
                             ValueType::float32};
  SampleRingMap m;
  m.record.value_type = types[rng() % 5];
  m.record.word_order = rng() % 2 ? WordOrder::big : WordOrder::little;
  m.record.status_address =
      rng() % 3 == 0 ? std::nullopt : std::optional<std::uint16_t>(register_count(m.record.value_type));
  m.record.scale_um = std::ldexp(1.0, static_cast<int>(rng() % 8) - 4);
  m.ring_samples = rng() % 4 == 0 ? 1u << (rng() % 9) : 1 + static_cast<std::uint32_t>(rng() % 700);
  m.ring_address = static_cast<std::uint16_t>(10 + rng() % 1000);
  m.counter_address = static_cast<std::uint16_t>(rng() % 8);
  m.counter_word_order = rng() % 2 ? WordOrder::big : WordOrder::little;
  return m;
}

}  // namespace

TEST(SampleRing, ParsesATableWithDefaults) {
  const SampleRingMap m = ring_from(minimal);
  EXPECT_TRUE(m.validate().empty());
  EXPECT_EQ(m.counter_address, 100);
  EXPECT_EQ(m.ring_address, 200);
  EXPECT_EQ(m.ring_samples, 1000u);
  EXPECT_DOUBLE_EQ(m.sample_rate_hz, 5000.0);
  EXPECT_EQ(m.record_registers(), 3);  // int32 + status
  EXPECT_EQ(m.samples_per_request(), 41u);
  const SampleRingMap f = ring_from(minimal + "value_type = \"float32\"\nword_order = \"little\"\nstatus = false\n"
                                              "function = \"holding\"\ncounter_word_order = \"little\"\n");
  EXPECT_EQ(f.record_registers(), 2);
  EXPECT_EQ(f.samples_per_request(), 62u);
  EXPECT_EQ(f.function, RegisterFunction::holding);
  EXPECT_EQ(decode_counter(f, 0x5678, 0x1234), 0x12345678u);
  EXPECT_EQ(decode_counter(m, 0x1234, 0x5678), 0x12345678u);
}

TEST(SampleRing, RejectsBadConfigWithFileLineAndKey) {
  EXPECT_NE(config_error("ring_address = 200\nring_samples = 10\nsample_rate_hz = 1\n")
                .find("test.toml:1: device[0].buffer.counter_address"),
            std::string::npos);
  EXPECT_NE(config_error(minimal + "value_type = \"int64\"\n").find("test.toml:5: device[0].buffer.value_type"),
            std::string::npos);
  // 30000 slots of 3 registers from 200 go past register 65535.
  EXPECT_NE(config_error("counter_address = 100\nring_address = 200\nring_samples = 30000\nsample_rate_hz = 1\n")
                .find("test.toml:3: device[0].buffer.ring_samples"),
            std::string::npos);
  EXPECT_NE(config_error("counter_address = 201\nring_address = 200\nring_samples = 10\nsample_rate_hz = 1\n")
                .find("overlap"),
            std::string::npos);
  EXPECT_NE(config_error(minimal + "sample_rate = 10\n").find("device[0].buffer.sample_rate"), std::string::npos);
  EXPECT_NE(config_error("counter_address = 100\nring_address = 200\nring_samples = 10\nsample_rate_hz = 0\n")
                .find("device[0].buffer.sample_rate_hz"),
            std::string::npos);
  EXPECT_NE(config_error(minimal + "scale_um = 0\n").find("scale_um"), std::string::npos);
  // The parser and validate() agree on the range, [0.001, 1e6] Hz (docs/protocols.md says the same).
  SampleRingMap m;
  for (const double hz : {1e-3, 1e6}) {
    m.sample_rate_hz = hz;
    EXPECT_EQ(m.validate(), "") << hz;
    EXPECT_EQ(config_error("counter_address = 100\nring_address = 200\nring_samples = 10\nsample_rate_hz = " +
                           std::to_string(hz) + "\n"),
              "accepted") << hz;
  }
  for (const double hz : {5e-4, 1.000001e6}) {
    m.sample_rate_hz = hz;
    EXPECT_NE(m.validate(), "") << hz;
  }
}

TEST(SampleRing, CounterUnwrapsAcrossTheWrapAndSpotsResets) {
  CounterTracker c;
  EXPECT_EQ(c.update(0xfffffff0u, 0.0, 1000.0), CounterTracker::Step::first);
  EXPECT_EQ(c.count(), 0xfffffff0u);
  EXPECT_EQ(c.update(0x10u, 0.1, 1000.0), CounterTracker::Step::advanced);  // 32 samples in 0.1 s at 1 kHz
  EXPECT_EQ(c.count(), 0x100000010u);
  EXPECT_EQ(c.update(0x10u, 0.1, 1000.0), CounterTracker::Step::advanced);  // none taken
  EXPECT_EQ(c.count(), 0x100000010u);
  // Backwards: the amplifier restarted. The count moves to a new epoch, keeping the low 32 bits.
  EXPECT_EQ(c.update(0x5u, 0.1, 1000.0), CounterTracker::Step::reset);
  EXPECT_EQ(c.count(), 0x200000005u);
  // More than 1.05 * rate * elapsed + 2: it restarted and counted past the old value.
  EXPECT_EQ(c.update(0x5u + 200u, 0.1, 1000.0), CounterTracker::Step::reset);
  EXPECT_EQ(c.count(), 0x3000000cdu);
  EXPECT_EQ(c.update(0xcdu + 107u, 0.1, 1000.0), CounterTracker::Step::advanced);  // 107 <= 105 + 2
}

// Against a model amplifier: a slot array that remembers which sample wrote it last (or is writing it).
TEST(SampleRing, OldestIntactMatchesAModelAmplifierAcrossCounterWraps) {
  std::mt19937_64 rng(8);
  for (int iter = 0; iter < 3000; ++iter) {
    SampleRingMap m = random_map(rng);
    m.ring_samples = 1 + static_cast<std::uint32_t>(rng() % 60);
    const std::uint64_t start = (std::uint64_t{1} << 32) * (rng() % 3) + 0xffffffffu - rng() % 200;
    const std::uint64_t taken = 1 + rng() % 400;
    std::vector<std::int64_t> owner(m.ring_samples, -1);
    const std::uint64_t count = start + taken;
    // Write-then-increment: with the counter at `count` the amplifier may be writing sample `count`
    // into its slot right now, so that slot holds nothing stable.
    for (std::uint64_t u = start; u <= count; ++u) owner[ring_slot(m, u)] = static_cast<std::int64_t>(u);
    const std::uint64_t oldest = std::max(oldest_intact(m, count), start);  // the model knows nothing before start
    ASSERT_LE(oldest, count);
    for (std::uint64_t u = oldest; u < count; ++u) {
      ASSERT_EQ(owner[ring_slot(m, u)], static_cast<std::int64_t>(u)) << "N=" << m.ring_samples << " u=" << u;
    }
    if (oldest > start) {
      ASSERT_NE(owner[ring_slot(m, oldest - 1)], static_cast<std::int64_t>(oldest - 1)) << "N=" << m.ring_samples;
    }
  }
}

// Random maps, random spans (across ring and counter wraps): the plan covers exactly the span, in
// order, within the 125-register limit, and decoding the model amplifier's registers through it gives
// back every sample as written, flags included. Mutated or short blocks are refused, never crash.
TEST(SampleRing, RandomizedPlanAndDecodeRoundTrip) {
  std::mt19937_64 rng(20261121);
  std::size_t samples_checked = 0, reads = 0;
  for (int iter = 0; iter < 4000; ++iter) {
    const SampleRingMap m = random_map(rng);
    ASSERT_TRUE(m.validate().empty()) << m.validate();
    const std::uint32_t n = m.ring_samples;
    const std::uint32_t rec = m.record_registers();
    const std::uint64_t start = (std::uint64_t{1} << 32) * (rng() % 2) + (rng() % 2 ? 0xffffffffu - rng() % 2000 : rng() % 5000);
    const std::uint64_t taken = 1 + rng() % (3 * n + 50);
    const std::uint64_t count = start + taken;
    // The model amplifier: registers of the whole ring, and the value/status written per sample.
    std::vector<std::uint16_t> regs(std::size_t{n} * rec, 0xdead);
    auto value_of = [&](std::uint64_t u) { return static_cast<double>(u % 20011) * m.record.scale_um * 1e-6; };
    auto status_of = [&](std::uint64_t u) { return static_cast<std::uint16_t>(u % 7 == 0 ? 0x0001 : u % 11 == 0 ? 0x0002 : 0); };
    for (std::uint64_t u = start; u < count; ++u) {
      const auto enc = encode_registers(m.record, value_of(u), status_of(u));
      std::copy(enc.begin(), enc.end(), regs.begin() + static_cast<std::ptrdiff_t>(ring_slot(m, u)) * rec);
    }
    const std::uint64_t first = std::max(oldest_intact(m, count), start) + rng() % 3;
    if (first > count) continue;
    const auto plan = plan_ring_reads(m, first, count);
    std::uint64_t expect = first;
    std::size_t wraps = 0;
    for (const RingRead& r : plan) {
      ASSERT_EQ(r.first, expect);
      ASSERT_GT(r.samples, 0u);
      ASSERT_LE(r.count, 125);
      ASSERT_EQ(r.count, r.samples * rec);
      ASSERT_EQ(r.address, m.ring_address + ring_slot(m, r.first) * rec);
      ASSERT_LE(r.address + r.count, m.ring_address + m.ring_registers());
      wraps += ring_slot(m, r.first) == 0 || static_cast<std::uint32_t>(r.first) == 0 ? 1 : 0;
      const std::span<const std::uint16_t> block(regs.data() + (r.address - m.ring_address), r.count);
      std::vector<Reading> out(r.samples);
      ASSERT_TRUE(decode_ring_block(m, r, block, out));
      for (std::uint32_t i = 0; i < r.samples; ++i) {
        const std::uint64_t u = r.first + i;
        const std::uint16_t st = status_of(u);
        const std::uint32_t flags = ((st & m.record.out_of_range_mask) ? std::uint32_t{sample_out_of_range} : 0u) |
                                    ((st & m.record.probe_missing_mask) ? std::uint32_t{sample_no_signal} : 0u);
        if (!m.record.status_address || flags == 0) {
          ASSERT_EQ(out[i].flags, 0u);
          ASSERT_NEAR(out[i].value_m, value_of(u), std::abs(value_of(u)) * 1e-6 + m.record.scale_um * 0.51e-6) << u;
        } else {
          ASSERT_EQ(out[i].flags, flags);
          ASSERT_TRUE(std::isnan(out[i].value_m));
        }
        ++samples_checked;
      }
      // A block one register short is refused and leaves the output alone.
      std::vector<Reading> untouched(r.samples);
      ASSERT_FALSE(decode_ring_block(m, r, block.first(block.size() - 1), untouched));
      ASSERT_FALSE(untouched[0].valid);
      expect += r.samples;
      ++reads;
    }
    ASSERT_EQ(expect, count);
    // As few requests as the limit allows: one per samples_per_request, plus one per wrap point.
    const std::uint64_t span = count - first;
    const std::uint64_t per = m.samples_per_request();
    ASSERT_LE(plan.size(), (span + per - 1) / per + 2) << "span " << span << " wraps " << wraps;
  }
  EXPECT_GT(samples_checked, 200000u);
  EXPECT_GT(reads, 10000u);
  // Spans longer than the ring or reversed are not planned.
  const SampleRingMap d;
  EXPECT_TRUE(plan_ring_reads(d, 0, d.ring_samples + 1).empty());
  EXPECT_TRUE(plan_ring_reads(d, 10, 5).empty());
}

// Random garbage blocks of random maps: decoding never fails when the block is long enough, and a
// value is either finite and unflagged or NaN and flagged.
TEST(SampleRing, RandomBlocksDecodeSafely) {
  std::mt19937_64 rng(77);
  for (int iter = 0; iter < 20000; ++iter) {
    const SampleRingMap m = random_map(rng);
    const RingRead r{m.ring_address, 0, rng(), static_cast<std::uint32_t>(1 + rng() % m.samples_per_request())};
    const std::size_t extra = rng() % 3;  // one register short, exact, or one more
    std::vector<std::uint16_t> block(std::size_t{r.samples} * m.record_registers() + extra - 1);
    for (auto& w : block) w = static_cast<std::uint16_t>(rng());
    std::vector<Reading> out(r.samples);
    const bool ok = decode_ring_block(m, r, block, out);
    ASSERT_EQ(ok, block.size() >= std::size_t{r.samples} * m.record_registers());
    if (!ok) continue;
    for (const Reading& x : out) {
      ASSERT_TRUE(x.valid);
      ASSERT_EQ(x.flags == 0, std::isfinite(x.value_m));
    }
  }
}

// Simulated polls of an amplifier whose sample k is taken at a0 + k/rate: every estimate is late by
// exactly the window's smallest delay between the newest sample and its answer (never early).
TEST(SampleRing, TimeAnchorIsLateByTheQuickestAnswerInItsWindow) {
  std::mt19937_64 rng(3);
  const double rate = 10000.0;
  const double a0 = 5e9;  // ns
  const std::int64_t window = 1'000'000'000;
  TimeAnchor anchor(rate, window);
  anchor.reset(0);
  std::vector<std::pair<std::int64_t, double>> polls;  // answer time, its lateness
  double t_query = a0 + 1e6;
  for (int i = 0; i < 2000; ++i) {
    t_query += 2e6 + static_cast<double>(rng() % 3000000);  // polls every 2-5 ms
    const auto count = static_cast<std::uint64_t>(std::floor((t_query - a0) * rate / 1e9)) + 1;  // sample 0 at a0
    const double delay = 30e3 + static_cast<double>(rng() % 400000);                            // 30-430 us
    const auto t_answer = static_cast<std::int64_t>(t_query + delay);
    anchor.observe(t_answer, count);
    polls.emplace_back(t_answer, static_cast<double>(t_answer) - (a0 + static_cast<double>(count - 1) * 1e9 / rate));
    double expected = 1e18;
    for (const auto& [t, late] : polls) {
      if (t >= t_answer - window) expected = std::min(expected, late);
    }
    ASSERT_TRUE(anchor.ready());
    const std::uint64_t k = count - 1 - rng() % 50;
    const double error = static_cast<double>(anchor.time_ns(k)) - (a0 + static_cast<double>(k) * 1e9 / rate);
    ASSERT_GE(error, 0.0);
    ASSERT_NEAR(error, expected, 1.0);
  }
}

// A device whose real rate is off the configured one: rate_error() measures it (to 1e-4 with answer
// delays up to 1 ms), and with a 0.2 s window a device 0.5 % slow gets stamps early by at most
// 0.2 s x 0.5 % = 1 ms (with a 1 s window, 5 ms).
TEST(SampleRing, TimeAnchorMeasuresTheDevicesRealRate) {
  for (const double real : {1.0, 0.995, 0.99, 1.004}) {
    std::mt19937_64 rng(7);
    const double rate = 10000.0, true_rate = rate * real;
    const double a0 = 5e9;
    TimeAnchor anchor(rate, 200'000'000);
    anchor.reset(0);
    double t_query = a0 + 1e6, most_early = 0.0;
    for (int i = 0; i < 700; ++i) {  // 3.5 s of polls every 5 ms
      t_query += 5e6;
      const auto count = static_cast<std::uint64_t>(std::floor((t_query - a0) * true_rate / 1e9)) + 1;
      const auto t_answer = static_cast<std::int64_t>(t_query + 30e3 + static_cast<double>(rng() % 1000000));
      anchor.observe(t_answer, count);
      const std::uint64_t k = count - 1 - rng() % 50;
      const double error = static_cast<double>(anchor.time_ns(k)) - (a0 + static_cast<double>(k) * 1e9 / true_rate);
      most_early = std::min(most_early, error);
    }
    const auto e = anchor.rate_error();
    ASSERT_TRUE(e) << real;
    EXPECT_NEAR(*e, real - 1.0, 1e-4) << real;
    EXPECT_GE(most_early, -0.2e9 * std::max(0.0, 1.0 / real - 1.0) - 1.0) << real;
  }
  TimeAnchor anchor(10000.0, 200'000'000);  // nothing before rate_span_ns of reads
  anchor.reset(0);
  for (int i = 1; i <= 190; ++i) anchor.observe(i * 5'000'000, static_cast<std::uint64_t>(i) * 50);
  EXPECT_FALSE(anchor.rate_error());
}

// The anchor drops 5 ms (a quicker answer): stamps never go below the anchor's times, stay at least
// half a period apart, and meet the anchor again after 100 samples (5 ms / 50 us), not 1 ns apart.
TEST(SampleRing, StampSequencerApproachesADroppedAnchorByHalfAPeriodPerSample) {
  const double rate = 10000.0;
  StampSequencer seq(rate);
  std::int64_t last = 0;
  for (std::uint64_t k = 0; k < 400; ++k) {
    const std::int64_t anchor = 1'000'000'000 + static_cast<std::int64_t>(k) * 100'000 - (k >= 200 ? 5'000'000 : 0);
    const std::int64_t t = seq.stamp(k, anchor);
    ASSERT_GE(t, anchor) << k;
    if (k > 0) {
      ASSERT_GE(t - last, 50'000) << k;
    }
    if (k < 200 || k >= 300) {
      ASSERT_EQ(t, anchor) << k;
    }
    last = t;
  }
  // A lap (k jumps): the bound grows with the jump; a restart: numbers jump by 2^32, only +1 is kept.
  EXPECT_EQ(seq.stamp(1399, last - 1), last + 1000 * 50'000);
  seq.restart();
  const std::int64_t before = last + 1000 * 50'000;
  EXPECT_EQ(seq.stamp((std::uint64_t{1} << 32) + 5, 0), before + 1);
}
