// Property and fuzz tests of the DBB CAN decoder (pure, no I/O): exact unwrapping across the 32-bit
// wrap, held values in partial cycles, and >100k random and mutated frames without a crash or a
// broken invariant. Run under ASan/UBSan in the sanitizer build.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "drivers/dbb/dbb_protocol.hpp"

using namespace guideway;
using namespace guideway::drivers::dbb;

namespace {

std::vector<EncoderScale> encoders() {
  return {{"bar_length", 1, 1e-7, +1, 0, 0.1}, {"x", 5, 1e-7, -1, 77, 0.0}, {"y", 127, 2.5e-8, +1, -5, 0.0}};
}

void check_cycle(const DbbCycle& c) {
  ASSERT_EQ(c.count, 3u);
  ASSERT_EQ(c.flags & ~(sample_partial | sample_after_gap), 0u);
  ASSERT_NE(c.present, 0u);
  ASSERT_EQ((c.flags & sample_partial) != 0, c.present != 0b111u);
  for (std::size_t i = 0; i < 3; ++i) {
    if (c.present & (1u << i)) {
      ASSERT_TRUE(std::isfinite(c.position_m[i]));
    }
  }
}

// Cycles a property test takes from the decoder: each well formed, their times strictly increasing.
struct TakenCycles {
  std::size_t count = 0;
  std::int64_t last_t_ns = -1;
  void take(const DbbCycle& c) {
    ++count;
    check_cycle(c);
    ASSERT_GT(c.t_sync_ns, last_t_ns);
    last_t_ns = c.t_sync_ns;
  }
};

}  // namespace

TEST(DbbProtocol, ClassifiesTheFramesOfTheProfile) {
  EXPECT_EQ(classify_frame(make_sync_frame()).kind, FrameInfo::Kind::sync);
  const auto p = classify_frame(make_position_pdo(5, 0xDEADBEEF));
  EXPECT_EQ(p.kind, FrameInfo::Kind::position);
  EXPECT_EQ(p.node, 5);
  EXPECT_EQ(p.count, 0xDEADBEEFu);
  can_frame f = make_position_pdo(5, 1);
  f.can_dlc = 3;
  EXPECT_EQ(classify_frame(f).kind, FrameInfo::Kind::bad);
  f = make_sync_frame();
  f.can_dlc = 1;
  EXPECT_EQ(classify_frame(f).kind, FrameInfo::Kind::sync) << "SYNC with a counter byte";
  f.can_dlc = 2;
  EXPECT_EQ(classify_frame(f).kind, FrameInfo::Kind::bad);
  f = make_position_pdo(5, 1);
  f.can_id |= CAN_RTR_FLAG;
  EXPECT_EQ(classify_frame(f).kind, FrameInfo::Kind::other);
  f.can_id = 0x085;
  EXPECT_EQ(classify_frame(f).kind, FrameInfo::Kind::emergency);
  f.can_id = CAN_ERR_FLAG | 0x40;
  EXPECT_EQ(classify_frame(f).kind, FrameInfo::Kind::error_frame);
  EXPECT_EQ(classify_frame(f).error_class, 0x40u);
  f.can_id = 0x181 | CAN_EFF_FLAG;
  f.can_dlc = 4;
  EXPECT_EQ(classify_frame(f).kind, FrameInfo::Kind::other);
}

TEST(DbbProtocol, TheExampleOfTheProtocolDocumentDecodesAsDocumented) {
  // docs/protocols.md: 080#, 181#E8030000, 182#40420F00, 183#C0BDF0FF -> [0.1001, 0.1, -0.1] m.
  DbbDecoder d({{"bar_length", 1, 1e-7, +1, 0, 0.1}, {"x", 2, 1e-7, +1, 0, 0.0}, {"y", 3, 1e-7, +1, 0, 0.0}});
  auto pdo = [](canid_t id, std::array<std::uint8_t, 4> b) {
    can_frame f{};
    f.can_id = id;
    f.can_dlc = 4;
    std::copy(b.begin(), b.end(), f.data);
    return f;
  };
  DbbCycle c;
  d.feed(make_sync_frame(), 1, c);
  d.feed(pdo(0x181, {0xE8, 0x03, 0x00, 0x00}), 2, c);
  d.feed(pdo(0x182, {0x40, 0x42, 0x0F, 0x00}), 3, c);
  ASSERT_TRUE(d.feed(pdo(0x183, {0xC0, 0xBD, 0xF0, 0xFF}), 4, c).cycle_ready);
  EXPECT_NEAR(c.position_m[0], 0.1001, 1e-12);
  EXPECT_NEAR(c.position_m[1], 0.1, 1e-12);
  EXPECT_NEAR(c.position_m[2], -0.1, 1e-12);
  EXPECT_EQ(c.flags, 0u);
  EXPECT_EQ(c.t_sync_ns, 1);
}

TEST(DbbProtocol, UnwrapsAcrossThe32BitWrapExactly) {
  std::mt19937_64 rng(42);
  DbbDecoder d(encoders());
  std::int64_t truth[3] = {0x7FFFFF00, -0x7FFFFF00, 0};  // start near the signed limits
  std::uniform_int_distribution<std::int64_t> step(-(1ll << 30), (1ll << 30));
  std::size_t cycles = 0;
  for (int k = 0; k < 20000; ++k) {
    DbbCycle c;
    d.feed(make_sync_frame(), k, c);
    for (std::size_t i = 0; i < 3; ++i) {
      if (k > 0) truth[i] += step(rng);
      const auto count = static_cast<std::uint32_t>(static_cast<std::uint64_t>(truth[i]) & 0xFFFFFFFFu);
      const auto r = d.feed(make_position_pdo(encoders()[i].node_id, count), k, c);
      ASSERT_EQ(r.cycle_ready, i == 2);
    }
    ++cycles;
    check_cycle(c);
    EXPECT_EQ(c.flags, 0u);
    for (std::size_t i = 0; i < 3; ++i) {
      // The first count is taken as signed 32-bit, so truth[] started inside that range.
      ASSERT_DOUBLE_EQ(c.position_m[i], count_to_position(encoders()[i], truth[i])) << k << " " << i;
    }
  }
  EXPECT_EQ(cycles, 20000u);
  EXPECT_GT(std::abs(truth[0]), 1ll << 31) << "the walk left the 32-bit range";
}

TEST(DbbProtocol, PositionToCountRoundTrips) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> pos(-0.5, 0.5);
  for (const auto& e : encoders()) {
    for (int k = 0; k < 10000; ++k) {
      const double p = e.offset_m + pos(rng);
      const std::uint32_t c = position_to_count(e, p);
      DbbDecoder d({e});
      DbbCycle cy;
      d.feed(make_sync_frame(), 0, cy);
      ASSERT_TRUE(d.feed(make_position_pdo(e.node_id, c), 0, cy).cycle_ready);
      ASSERT_NEAR(cy.position_m[0], p, e.resolution_m * 0.5 + 1e-15);
    }
  }
}

TEST(DbbProtocol, PartialCyclesHoldAndMissedSyncsAreInferred) {
  DbbDecoder d(encoders());
  DbbCycle c;
  d.feed(make_sync_frame(), 1, c);
  d.feed(make_position_pdo(1, 10), 1, c);
  d.feed(make_position_pdo(5, 20), 1, c);
  ASSERT_TRUE(d.feed(make_position_pdo(127, 30), 1, c).cycle_ready);
  const double held_x = c.position_m[1];
  d.feed(make_sync_frame(), 2, c);
  d.feed(make_position_pdo(1, 11), 2, c);
  d.feed(make_position_pdo(127, 31), 2, c);
  auto r = d.feed(make_sync_frame(), 3, c);  // node 5 missed SYNC 2
  ASSERT_TRUE(r.cycle_ready);
  EXPECT_EQ(c.t_sync_ns, 2);
  EXPECT_EQ(c.flags, static_cast<std::uint32_t>(sample_partial));
  EXPECT_EQ(c.present, 0b101u);
  EXPECT_EQ(c.position_m[1], held_x);
  // No node answers SYNC 3 and 4: no sample; then a node sends twice without SYNC between.
  EXPECT_FALSE(d.feed(make_sync_frame(), 4, c).cycle_ready);
  EXPECT_FALSE(d.feed(make_position_pdo(1, 12), 4, c).cycle_ready);
  r = d.feed(make_position_pdo(1, 13), 5, c);
  ASSERT_TRUE(r.cycle_ready);
  EXPECT_EQ(c.present, 0b001u);
  EXPECT_EQ(d.missed_syncs(), 1u);
  d.feed(make_position_pdo(5, 21), 5, c);
  ASSERT_TRUE(d.feed(make_position_pdo(127, 32), 5, c).cycle_ready);
  EXPECT_TRUE(c.flags & sample_after_gap);
  EXPECT_EQ(c.t_sync_ns, 5);
  // PDOs before any SYNC are ignored; resync marks the next cycle.
  DbbDecoder d2(encoders());
  EXPECT_FALSE(d2.feed(make_position_pdo(1, 1), 0, c).cycle_ready);
  d2.resync();
  d2.feed(make_sync_frame(), 1, c);
  d2.feed(make_position_pdo(1, 1), 1, c);
  d2.feed(make_position_pdo(5, 1), 1, c);
  ASSERT_TRUE(d2.feed(make_position_pdo(127, 1), 1, c).cycle_ready);
  EXPECT_EQ(c.flags, static_cast<std::uint32_t>(sample_after_gap));
}

// As the SYNC producer the decoder knows every SYNC: a node's second answer within a cycle is a late one
// and replaces the first, an answer that straddles our SYNC is split at the SYNC's time, and no SYNC
// becomes two samples.
TEST(DbbProtocol, AsSyncProducerLateAnswersReplaceAndNoSyncBecomesTwoSamples) {
  DbbDecoder d(encoders(), true);
  DbbCycle c;
  EXPECT_FALSE(d.sync_sent(100, 100, c));
  EXPECT_FALSE(d.feed(make_position_pdo(1, 10), 110, c).cycle_ready);
  EXPECT_FALSE(d.feed(make_position_pdo(5, 20), 110, c).cycle_ready);
  ASSERT_TRUE(d.feed(make_position_pdo(127, 30), 120, c).cycle_ready) << "in time: published when complete";
  EXPECT_EQ(c.t_sync_ns, 100);
  const double x_100 = c.position_m[1];
  // Node 127 answers SYNC 200 in time on the bus, but it is read after our SYNC 300: still cycle 200's.
  EXPECT_FALSE(d.sync_sent(200, 200, c));
  d.feed(make_position_pdo(1, 11), 210, c);
  d.feed(make_position_pdo(5, 21), 210, c);
  EXPECT_FALSE(d.sync_sent(300, 300, c)) << "incomplete at the SYNC: held, not yet published";
  ASSERT_TRUE(d.feed(make_position_pdo(127, 31), 290, c).cycle_ready);
  EXPECT_EQ(c.t_sync_ns, 200);
  EXPECT_EQ(c.present, 0b111u);
  EXPECT_EQ(c.flags, 0u);
  // The nodes are behind: the complete cycle 300 waits for SYNC 400, and a second answer replaces the first.
  d.feed(make_position_pdo(1, 12), 310, c);
  d.feed(make_position_pdo(5, 22), 310, c);
  EXPECT_FALSE(d.feed(make_position_pdo(127, 32), 320, c).cycle_ready);
  EXPECT_FALSE(d.feed(make_position_pdo(127, 40), 330, c).cycle_ready);
  EXPECT_EQ(d.late_pdos(), 1u);
  ASSERT_TRUE(d.sync_sent(400, 400, c));
  EXPECT_EQ(c.t_sync_ns, 300);
  EXPECT_EQ(c.flags, 0u);
  DbbDecoder reference(encoders(), true);  // the value of count 40 alone
  DbbCycle r;
  reference.sync_sent(0, 0, r);
  reference.feed(make_position_pdo(1, 0), 1, r);
  reference.feed(make_position_pdo(5, 0), 1, r);
  ASSERT_TRUE(reference.feed(make_position_pdo(127, 40), 1, r).cycle_ready);
  EXPECT_DOUBLE_EQ(c.position_m[2], r.position_m[2]);
  // Complete in time again: published at once.
  d.feed(make_position_pdo(1, 13), 410, c);
  d.feed(make_position_pdo(5, 23), 410, c);
  ASSERT_TRUE(d.feed(make_position_pdo(127, 33), 410, c).cycle_ready);
  EXPECT_EQ(c.t_sync_ns, 400);
  const double x_400 = c.position_m[1];
  EXPECT_NE(x_400, x_100);
  // An answer straddling our SYNC: what came before it is cycle 500's (the rest held), the rest 600's.
  EXPECT_FALSE(d.sync_sent(500, 500, c));
  d.feed(make_position_pdo(1, 14), 510, c);
  EXPECT_FALSE(d.sync_sent(600, 600, c));
  ASSERT_TRUE(d.feed(make_position_pdo(5, 24), 610, c).cycle_ready);
  EXPECT_EQ(c.t_sync_ns, 500);
  EXPECT_EQ(c.present, 0b001u);
  EXPECT_EQ(c.flags, static_cast<std::uint32_t>(sample_partial));
  EXPECT_EQ(c.position_m[1], x_400) << "the missing channel holds its last value";
  d.feed(make_position_pdo(127, 34), 615, c);
  EXPECT_FALSE(d.feed(make_position_pdo(1, 15), 620, c).cycle_ready) << "behind: waits for the next SYNC";
  ASSERT_TRUE(d.sync_sent(700, 700, c));
  EXPECT_EQ(c.t_sync_ns, 600);
  EXPECT_EQ(c.present, 0b111u);
  // No answer: no sample. A held cycle is not lost when the connection ends.
  EXPECT_FALSE(d.sync_sent(800, 800, c));
  d.feed(make_position_pdo(1, 16), 810, c);
  EXPECT_FALSE(d.sync_sent(900, 900, c));
  ASSERT_TRUE(d.flush(c));
  EXPECT_EQ(c.t_sync_ns, 800);
  EXPECT_EQ(c.present, 0b001u);
  EXPECT_FALSE(d.flush(c));
  EXPECT_EQ(d.empty_cycles(), 1u);
}

// Our SYNC reaches the bus somewhere within its write: an answer to the SYNC before, stamped while this
// one was being written (a driver held up between its clock read and the write), is the cycle
// before's, even when that cycle had nothing yet; a cycle nobody answered is still no sample, and the
// one after it says so.
TEST(DbbProtocol, AsSyncProducerAnAnswerStampedWhileOurSyncWasWrittenIsTheCycleBefores) {
  DbbDecoder d(encoders(), true);
  DbbCycle c;
  EXPECT_FALSE(d.sync_sent(100, 101, c));
  d.feed(make_position_pdo(1, 10), 110, c);
  d.feed(make_position_pdo(5, 20), 110, c);
  ASSERT_TRUE(d.feed(make_position_pdo(127, 30), 110, c).cycle_ready);
  EXPECT_FALSE(d.sync_sent(200, 201, c));
  EXPECT_FALSE(d.sync_sent(300, 310, c)) << "nothing of cycle 200 yet: held, not an empty cycle";
  d.feed(make_position_pdo(1, 11), 305, c);
  d.feed(make_position_pdo(5, 21), 305, c);
  ASSERT_TRUE(d.feed(make_position_pdo(127, 31), 306, c).cycle_ready);
  EXPECT_EQ(c.t_sync_ns, 200);
  EXPECT_EQ(c.present, 0b111u);
  EXPECT_EQ(c.flags, 0u) << "no hole: cycle 200 was answered";
  // Cycle 300's own answers, after the write: cycle 300 (behind: published at the next SYNC).
  d.feed(make_position_pdo(1, 12), 320, c);
  d.feed(make_position_pdo(5, 22), 320, c);
  EXPECT_FALSE(d.feed(make_position_pdo(127, 32), 320, c).cycle_ready);
  ASSERT_TRUE(d.sync_sent(400, 401, c));
  EXPECT_EQ(c.t_sync_ns, 300);
  EXPECT_EQ(c.present, 0b111u);
  EXPECT_EQ(d.empty_cycles(), 0u);
  // Nobody answers SYNC 400 before SYNC 500's write returned: no sample, and cycle 500 follows a hole.
  EXPECT_FALSE(d.sync_sent(500, 501, c));
  EXPECT_FALSE(d.feed(make_position_pdo(1, 13), 510, c).cycle_ready);
  d.feed(make_position_pdo(5, 23), 510, c);
  d.feed(make_position_pdo(127, 33), 510, c);
  ASSERT_TRUE(d.sync_sent(600, 601, c));
  EXPECT_EQ(c.t_sync_ns, 500);
  EXPECT_EQ(c.flags, static_cast<std::uint32_t>(sample_after_gap));
  EXPECT_EQ(d.empty_cycles(), 1u);
  // Cycle 600 lacks node 1 (rebooting) at SYNC 700: node 1's answer stamped during SYNC 700's write is
  // already 700's (the node, woken by the write, ran first), not 600's.
  d.feed(make_position_pdo(5, 24), 610, c);
  d.feed(make_position_pdo(127, 34), 610, c);
  EXPECT_FALSE(d.sync_sent(700, 710, c));
  ASSERT_TRUE(d.feed(make_position_pdo(1, 15), 705, c).cycle_ready);
  EXPECT_EQ(c.t_sync_ns, 600);
  EXPECT_EQ(c.present, 0b110u);
  EXPECT_TRUE(c.flags & sample_partial);
}

// With our SYNC echoed by the bus, the order decides, not the times. The bench's case under load (an
// emulator held up twice running): the answer to SYNC 200 stamped after SYNC 300 was written, the answer
// to 300 after 400 was written. By times, cycle 200 was empty and 300 got 200's values; by the echoes,
// each cycle has its own, at its echo's time, and a hole of two periods or more is flagged.
TEST(DbbProtocol, AsSyncProducerTheEchoOfOurSyncOrdersTheAnswers) {
  DbbDecoder d(encoders(), true, 100);
  DbbCycle c;
  const auto answer = [&](std::uint32_t count, std::int64_t t) {
    d.feed(make_position_pdo(1, count), t, c);
    d.feed(make_position_pdo(5, count), t, c);
    return d.feed(make_position_pdo(127, count), t, c).cycle_ready;
  };
  EXPECT_FALSE(d.sync_sent(100, 101, c));
  EXPECT_FALSE(d.feed(make_sync_frame(), 102, c).cycle_ready) << "the first echo: nothing before it";
  ASSERT_TRUE(answer(10, 110)) << "complete at its last PDO";
  EXPECT_EQ(c.t_sync_ns, 102);
  EXPECT_FALSE(d.sync_sent(200, 201, c));
  EXPECT_FALSE(d.sync_sent(300, 301, c)) << "the echo, not our write, closes cycle 200";
  EXPECT_FALSE(d.feed(make_sync_frame(), 250, c).cycle_ready);  // SYNC 200, read late by the bus
  ASSERT_TRUE(answer(20, 305)) << "stamped after SYNC 300's write, yet before its echo: 200's";
  EXPECT_EQ(c.t_sync_ns, 250);
  EXPECT_EQ(c.present, 0b111u);
  EXPECT_EQ(c.position_m[0], count_to_position(encoders()[0], 20));
  EXPECT_FALSE(d.sync_sent(400, 401, c));
  EXPECT_FALSE(d.feed(make_sync_frame(), 402, c).cycle_ready);  // SYNC 300's echo (the bus: 300 at 402)
  EXPECT_FALSE(d.feed(make_sync_frame(), 403, c).cycle_ready) << "SYNC 400: 300 had no answer";
  EXPECT_EQ(d.empty_cycles(), 1u);
  ASSERT_TRUE(answer(40, 410));
  EXPECT_EQ(c.t_sync_ns, 403);
  EXPECT_EQ(c.flags, static_cast<std::uint32_t>(sample_after_gap)) << "after the empty cycle";
  EXPECT_EQ(d.late_pdos(), 0u);
  // A partial cycle goes out at the next echo, its missing node held; an echo 2 periods late is a hole.
  EXPECT_FALSE(d.sync_sent(500, 501, c));
  EXPECT_FALSE(d.feed(make_sync_frame(), 502, c).cycle_ready);
  d.feed(make_position_pdo(1, 50), 510, c);
  d.feed(make_position_pdo(5, 50), 510, c);
  EXPECT_FALSE(d.sync_sent(600, 601, c));
  EXPECT_FALSE(d.sync_sent(700, 701, c));
  ASSERT_TRUE(d.feed(make_sync_frame(), 702, c).cycle_ready) << "SYNC 600 lost on the bus: the echo of 700";
  EXPECT_EQ(c.t_sync_ns, 502);
  EXPECT_EQ(c.present, 0b011u);
  EXPECT_EQ(c.position_m[2], count_to_position(encoders()[2], 40)) << "held";
  ASSERT_TRUE(answer(70, 710));
  EXPECT_EQ(c.t_sync_ns, 702);
  EXPECT_TRUE(c.flags & sample_after_gap) << "200 ns after the echo before: a hole";
  // A new connection: by times again until its bus echoes.
  d.resync();
  EXPECT_FALSE(d.sync_sent(800, 801, c));
  EXPECT_FALSE(answer(80, 810)) << "no echo yet: by the times (after a reconnect, published at the next SYNC)";
  ASSERT_TRUE(d.sync_sent(900, 901, c));
  EXPECT_EQ(c.t_sync_ns, 800);
  EXPECT_TRUE(c.flags & sample_after_gap);
}

// Random answers (late, early, missing, repeated) to a producer's SYNCs: never more samples than SYNCs,
// times strictly increasing, every sample well formed.
TEST(DbbProtocol, AsSyncProducerRandomAnswersNeverGiveMoreSamplesThanSyncs) {
  std::mt19937 rng(20261125);
  DbbDecoder d(encoders(), true);
  std::size_t syncs = 0;
  std::int64_t t = 0;
  TakenCycles taken;
  for (int step = 0; step < 200000; ++step) {
    DbbCycle c;
    t += 1 + static_cast<std::int64_t>(rng() % 50);
    if (rng() % 5 == 0) {
      ++syncs;
      const std::int64_t written = t + static_cast<std::int64_t>(rng() % 30);  // the write's own time
      if (d.sync_sent(t, written, c)) taken.take(c);
      t = written;
    } else {
      // Stamped up to 100 ns before it is read: possibly before the last SYNC.
      const std::int64_t stamp = t - static_cast<std::int64_t>(rng() % 100);
      const std::uint8_t node = encoders()[rng() % 3].node_id;
      if (d.feed(make_position_pdo(node, static_cast<std::uint32_t>(rng() % 1000)), stamp, c).cycle_ready) taken.take(c);
    }
    if (::testing::Test::HasFatalFailure()) return;
  }
  DbbCycle c;
  if (d.flush(c)) taken.take(c);
  EXPECT_LE(taken.count, syncs);
  EXPECT_GT(taken.count, syncs / 2);
  EXPECT_GT(d.late_pdos(), 1000u);
}

// The same with the bus echoing our SYNCs, late, bunched or lost (the nodes saw the SYNC, we did not see
// its echo): one sample per SYNC on the bus at most, times strictly increasing, every sample well formed,
// and once echoes come no answer is taken as late.
TEST(DbbProtocol, AsSyncProducerRandomEchoesNeverGiveMoreSamplesThanSyncs) {
  std::mt19937 rng(20261129);
  DbbDecoder d(encoders(), true, 200);
  std::size_t on_bus = 0, unechoed = 0;
  std::uint32_t answered = 0;  // nodes that answered the last SYNC on the bus
  std::uint64_t late_at_first_echo = 0;
  bool echoed = false;
  std::int64_t t = 0;
  TakenCycles taken;
  for (int step = 0; step < 200000; ++step) {
    DbbCycle c;
    t += 1 + static_cast<std::int64_t>(rng() % 50);
    const auto r = rng() % 10;
    if (r < 2) {
      ++unechoed;
      if (d.sync_sent(t, t + static_cast<std::int64_t>(rng() % 30), c)) taken.take(c);
    } else if (r < 4 && unechoed > 0) {  // the bus takes our oldest SYNC; its echo may be lost
      --unechoed;
      ++on_bus;
      answered = 0;
      if (rng() % 8 == 0) continue;
      if (!echoed) late_at_first_echo = d.late_pdos();
      echoed = true;
      if (d.feed(make_sync_frame(), t, c).cycle_ready) taken.take(c);
    } else if (on_bus > 0) {
      const std::size_t i = rng() % 3;
      if (answered & (1u << i)) continue;  // a node answers a SYNC once
      answered |= 1u << i;
      if (d.feed(make_position_pdo(encoders()[i].node_id, static_cast<std::uint32_t>(rng() % 1000)), t, c).cycle_ready)
        taken.take(c);
    }
    if (::testing::Test::HasFatalFailure()) return;
  }
  DbbCycle c;
  if (d.flush(c)) taken.take(c);
  EXPECT_LE(taken.count, on_bus);
  EXPECT_GT(taken.count, on_bus / 2);
  EXPECT_GT(d.missed_syncs(), 0u) << "a lost echo is a SYNC missed";
  EXPECT_EQ(d.late_pdos(), late_at_first_echo);
}

TEST(DbbProtocol, FuzzRandomAndMutatedFramesKeepTheInvariants) {
  std::mt19937 rng(20261121);
  DbbDecoder d(encoders());
  std::size_t inputs = 0, cycles = 0, bad = 0;
  std::uniform_int_distribution<int> byte(0, 255);
  const std::uint32_t ids[] = {0x080, 0x181, 0x185, 0x1FF, 0x085, 0x700, 0x000, 0x7FF};
  std::int64_t t = 0;
  std::uint32_t count[3] = {0, 0, 0};
  while (inputs < 300000) {
    can_frame f{};
    const int kind = static_cast<int>(rng() % 4);
    if (kind == 0) {
      // Pure noise: any id with any flags, any DLC (also > 8), any payload.
      f.can_id = static_cast<canid_t>(rng());
      f.can_dlc = static_cast<std::uint8_t>(rng() % 16);
      for (auto& b : f.data) b = static_cast<std::uint8_t>(byte(rng));
    } else if (kind == 1) {
      f.can_id = ids[rng() % 8];
      f.can_dlc = static_cast<std::uint8_t>(rng() % 9);
      for (auto& b : f.data) b = static_cast<std::uint8_t>(byte(rng));
    } else {
      // A valid frame of a valid cycle, then maybe mutated (one bit of the 16 bytes flipped).
      const int which = static_cast<int>(rng() % 4);
      if (which == 3) {
        f = make_sync_frame();
      } else {
        count[which] += static_cast<std::uint32_t>(rng() % 2001) - 1000u;
        f = make_position_pdo(encoders()[static_cast<std::size_t>(which)].node_id, count[which]);
      }
      if (kind == 3) {
        unsigned char raw[sizeof f];
        std::memcpy(raw, &f, sizeof f);
        raw[rng() % sizeof raw] ^= static_cast<unsigned char>(1u << (rng() % 8));
        std::memcpy(&f, raw, sizeof f);
      }
    }
    DbbCycle c;
    const auto r = d.feed(f, ++t, c);
    ++inputs;
    bad += r.info.kind == FrameInfo::Kind::bad;
    if (r.cycle_ready) {
      ++cycles;
      check_cycle(c);
      ASSERT_LE(c.t_sync_ns, t);
    }
  }
  EXPECT_GT(cycles, 1000u);
  EXPECT_GT(bad, 1000u);
}
