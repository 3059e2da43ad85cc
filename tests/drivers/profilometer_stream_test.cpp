// The profile stream codec and assembler: known lines, round trips, traverse assembly with start/end
// marks, and a randomized property test over random and mutated streams (>= 100k inputs).
#include "drivers/profilometer/profile_stream.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/sample.hpp"

using namespace guideway;
using namespace guideway::drivers::profilometer;

namespace {

ProfileHeader header(std::uint64_t id, std::uint64_t points) {
  ProfileHeader h;
  h.id = id;
  h.points = points;
  h.spacing_m = 0.5e-6;
  h.length_m = 0.5e-6 * static_cast<double>(points - 1);
  h.stylus = "2um";
  h.tip_radius_m = 2e-6;
  return h;
}

std::string traverse(std::uint64_t id, std::uint64_t points) {
  const ProfileHeader h = header(id, points);
  std::string s = format_header(h);
  for (std::uint64_t i = 0; i < points; ++i) {
    s += format_point(i, static_cast<double>(i) * 0.5e-6, 1e-7 * std::sin(static_cast<double>(i)), h, i == 3);
  }
  return s + format_end(id, points);
}

std::vector<StreamEvent> assemble(const std::string& bytes, bool finish = true) {
  ProfileAssembler a;
  std::vector<StreamEvent> out;
  a.feed(bytes, 1, out);
  if (finish) a.finish(out);
  return out;
}

}  // namespace

TEST(ProfileStream, FramesAndParsesEveryRecord) {
  EXPECT_EQ(frame_line("IDLE"), "IDLE*04\n");  // 'I'^'D'^'L'^'E' = 0x04
  auto p = parse_line("P 12 0.006000 -0.1250*" + frame_line("P 12 0.006000 -0.1250").substr(22, 2));
  ASSERT_TRUE(p);
  EXPECT_EQ(p->kind, LineKind::point);
  EXPECT_EQ(p->index, 12u);
  EXPECT_DOUBLE_EQ(p->x, 0.006);
  EXPECT_DOUBLE_EQ(p->z, -0.125);
  const std::string h = format_header(header(7, 100));
  auto ph = parse_line(std::string_view(h).substr(0, h.size() - 1));
  ASSERT_TRUE(ph);
  EXPECT_EQ(ph->kind, LineKind::header);
  EXPECT_EQ(ph->header.id, 7u);
  EXPECT_EQ(ph->header.points, 100u);
  EXPECT_NEAR(ph->header.spacing_m, 0.5e-6, 1e-15);
  EXPECT_EQ(ph->header.stylus, "2um");
  std::string why;
  EXPECT_FALSE(parse_line("P 1 2 3*00", &why));
  EXPECT_EQ(why, "checksum mismatch");
  EXPECT_FALSE(parse_line(frame_line("HDR id=1 points=3").substr(0, 20), &why));  // truncated
  const std::string no_spacing = frame_line("HDR id=1 points=3");
  EXPECT_FALSE(parse_line(std::string_view(no_spacing).substr(0, no_spacing.size() - 1), &why));
  EXPECT_NE(why.find("spacing_um"), std::string::npos);
  const std::string crlf = frame_line("END 3 10");
  EXPECT_TRUE(parse_line(crlf.substr(0, crlf.size() - 1) + "\r"));
}

TEST(ProfileStream, AssemblesATraverseWithStartEndAndOverRange) {
  const auto events = assemble(format_banner("test") + traverse(5, 10) + format_idle());
  std::vector<StreamEvent> points;
  for (const auto& e : events) {
    if (e.type == StreamEvent::Type::point) points.push_back(e);
    EXPECT_NE(e.type, StreamEvent::Type::bad_line) << e.message;
  }
  ASSERT_EQ(points.size(), 10u);
  EXPECT_EQ(points[0].flags, sample_profile_start);
  EXPECT_EQ(points[9].flags, sample_profile_end);
  EXPECT_EQ(points[3].flags, std::uint32_t{sample_out_of_range});
  EXPECT_TRUE(std::isnan(points[3].z_m));
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(points[i].profile_id, 5u);
    EXPECT_EQ(points[i].index, i);
    EXPECT_NEAR(points[i].x_m, static_cast<double>(i) * 0.5e-6, 1e-12);
  }
}

TEST(ProfileStream, ByteByByteFeedingGivesTheSameEvents) {
  const std::string s = traverse(1, 20) + traverse(2, 7);
  ProfileAssembler a;
  std::vector<StreamEvent> out;
  for (char c : s) a.feed(std::string_view(&c, 1), 1, out);
  a.finish(out);
  const auto whole = assemble(s);
  ASSERT_EQ(out.size(), whole.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i].type, whole[i].type);
    EXPECT_EQ(out[i].index, whole[i].index);
    EXPECT_EQ(out[i].flags, whole[i].flags);
  }
}

TEST(ProfileStream, ALostPointFlagsTheNextAndAMissingEndLeavesNoEndMark) {
  std::string s = traverse(1, 6);
  const std::string lost = format_point(2, 1e-6, 0.0, header(1, 6));
  s.replace(s.find(lost.substr(0, 4)), lost.size(), "P 2 garbage*00\n");
  auto events = assemble(s);
  std::vector<StreamEvent> points;
  int bad = 0;
  for (const auto& e : events) {
    if (e.type == StreamEvent::Type::point) points.push_back(e);
    bad += e.type == StreamEvent::Type::bad_line ? 1 : 0;
  }
  EXPECT_EQ(bad, 1);
  ASSERT_EQ(points.size(), 5u);
  EXPECT_EQ(points[2].index, 3u);
  EXPECT_TRUE(points[2].flags & sample_after_gap);
  // A point lost inside makes the traverse partial as much as one lost at its tail.
  EXPECT_EQ(points[4].flags & (sample_profile_end | sample_partial), sample_profile_end | sample_partial);
  ASSERT_EQ(events.back().type, StreamEvent::Type::end);
  EXPECT_EQ(events.back().points_lost, 1u);
  std::string tail = traverse(2, 6);
  tail.erase(tail.find("P 5"), format_point(5, 2.5e-6, 0.0, header(2, 6)).size());
  events = assemble(tail);
  ASSERT_EQ(events.back().type, StreamEvent::Type::end);
  EXPECT_EQ(events.back().points_lost, 1u);
  EXPECT_TRUE(events[events.size() - 2].flags & sample_partial);
  events = assemble(traverse(3, 6));
  ASSERT_EQ(events.back().type, StreamEvent::Type::end);
  EXPECT_EQ(events.back().points_lost, 0u);
  EXPECT_FALSE(events[events.size() - 2].flags & sample_partial);
  // Connection ends mid-traverse: the held point is released without an end mark.
  const std::string partial = traverse(9, 6);
  events = assemble(partial.substr(0, partial.rfind("END")));
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().type, StreamEvent::Type::point);
  EXPECT_EQ(events.back().index, 5u);
  EXPECT_FALSE(events.back().flags & sample_profile_end);
}

TEST(ProfileStream, RandomAndMutatedStreamsKeepTheInvariants) {
  std::mt19937_64 rng(1240);
  const std::string valid = format_banner("fuzz") + traverse(1, 16) + format_idle() + traverse(2, 6);
  std::size_t inputs = 0, points_seen = 0;
  for (int iter = 0; iter < 120000; ++iter) {
    std::string s;
    switch (iter % 3) {
      case 0: {  // random bytes, biased towards the protocol's alphabet
        static const char alphabet[] = "P HDRENDIL=*0123456789.-ABCDEF\n\r";
        s.resize(rng() % 400);
        for (auto& c : s) c = (rng() % 4 == 0) ? static_cast<char>(rng()) : alphabet[rng() % (sizeof(alphabet) - 1)];
        break;
      }
      default: {  // a valid stream with a few byte mutations, deletions and insertions
        s = valid;
        const int edits = 1 + static_cast<int>(rng() % 6);
        for (int e = 0; e < edits && !s.empty(); ++e) {
          const std::size_t at = rng() % s.size();
          switch (rng() % 3) {
            case 0:
              s[at] = static_cast<char>(rng());
              break;
            case 1:
              s.erase(at, 1 + rng() % 20);
              break;
            default:
              s.insert(at, std::string(1 + rng() % 5, static_cast<char>(rng())));
              break;
          }
        }
      }
    }
    ProfileAssembler a;
    std::vector<StreamEvent> out;
    std::size_t pos = 0;
    while (pos < s.size()) {  // random chunking, as TCP delivers
      const std::size_t n = std::min(s.size() - pos, 1 + static_cast<std::size_t>(rng() % 64));
      a.feed(std::string_view(s).substr(pos, n), static_cast<std::int64_t>(pos), out);
      pos += n;
    }
    a.finish(out);
    ++inputs;
    std::uint64_t last_profile = 0, last_index = 0;
    bool have_last = false;
    for (const auto& e : out) {
      if (e.type != StreamEvent::Type::point) continue;
      ++points_seen;
      ASSERT_TRUE(std::isfinite(e.x_m));
      ASSERT_EQ(std::isnan(e.z_m), (e.flags & sample_out_of_range) != 0);
      if (have_last && e.profile_id == last_profile) {
        ASSERT_GT(e.index, last_index);  // within one traverse, points only move forward
      }
      last_profile = e.profile_id;
      last_index = e.index;
      have_last = true;
    }
  }
  EXPECT_GE(inputs, 100000u);
  EXPECT_GT(points_seen, 50000u);
}
