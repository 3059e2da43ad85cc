// Property and fuzz tests of the autocollimator protocol (pure): format/parse round trips, canonical
// re-formatting of anything accepted, every single-byte corruption caught by the checksum, and
// >100k random and mutated lines without a crash. Run under ASan/UBSan in the sanitizer build.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "drivers/autocollimator/autocollimator_driver.hpp"
#include "drivers/autocollimator/autocollimator_protocol.hpp"
#include "drivers/serial/serial_port.hpp"

using namespace guideway;
using namespace guideway::drivers::autocollimator;

namespace {

Reading random_reading(std::mt19937& rng) {
  Reading r;
  r.relative = rng() % 2 == 0;
  const AxisState states[] = {AxisState::valid, AxisState::valid, AxisState::out_of_range, AxisState::no_reflection};
  r.x_state = states[rng() % 4];
  r.y_state = states[rng() % 4];
  std::uniform_int_distribution<int> hundredths(-999999, 999999);
  r.x_arcsec = hundredths(rng) / 100.0;
  r.y_arcsec = hundredths(rng) / 100.0;
  return r;
}

bool same(const Reading& a, const Reading& b) {
  auto axis = [](AxisState sa, double va, AxisState sb, double vb) {
    return sa == sb && (sa != AxisState::valid || std::fabs(va - vb) < 1e-9);
  };
  return a.relative == b.relative && axis(a.x_state, a.x_arcsec, b.x_state, b.x_arcsec) &&
         axis(a.y_state, a.y_arcsec, b.y_state, b.y_arcsec);
}

}  // namespace

TEST(AutocollimatorProtocol, ExamplesFromTheProtocolDocument) {
  Reading r;
  ASSERT_EQ(parse_reply("4 003 +12.34 -0.56", false, r), ParseError::none);
  EXPECT_FALSE(r.relative);
  EXPECT_DOUBLE_EQ(r.x_arcsec, 12.34);
  EXPECT_DOUBLE_EQ(r.y_arcsec, -0.56);
  ASSERT_EQ(parse_reply("2 103 -600.00 +0.01", false, r), ParseError::none);
  EXPECT_TRUE(r.relative);
  ASSERT_EQ(parse_reply("4 000 ---- ----", false, r), ParseError::none);
  EXPECT_EQ(r.x_state, AxisState::no_reflection);
  ASSERT_EQ(parse_reply("4 013 OVER +3.00", false, r), ParseError::none);
  EXPECT_EQ(r.x_state, AxisState::out_of_range);
  EXPECT_EQ(parse_reply("4 003 OVER +3.00", false, r), ParseError::inconsistent);
  EXPECT_EQ(parse_reply("4 103 +1.00 +3.00", false, r), ParseError::inconsistent);
  EXPECT_EQ(parse_reply("4 001 +1.00 +3.00", false, r), ParseError::inconsistent);
  EXPECT_EQ(parse_reply("4 003 +1.0 +3.00", false, r), ParseError::bad_value);
  EXPECT_EQ(parse_reply("4 003 1.00 +3.00", false, r), ParseError::bad_value);
  EXPECT_EQ(parse_reply("3 003 +1.00 +3.00", false, r), ParseError::bad_type);
  EXPECT_EQ(parse_reply("4 03 +1.00 +3.00", false, r), ParseError::bad_status);
  EXPECT_EQ(parse_reply("4 003 +1.00", false, r), ParseError::field_count);
  const std::string with = "4 003 +1.00 +3.00*" + checksum_hex("4 003 +1.00 +3.00");
  EXPECT_EQ(parse_reply(with, true, r), ParseError::none);
  EXPECT_EQ(parse_reply("4 003 +1.00 +3.00", true, r), ParseError::no_checksum);
  EXPECT_EQ(format_reply({false, AxisState::valid, AxisState::valid, 12.344, -0.555}, 1000, false),
            "4 003 +12.34 -0.56");
  EXPECT_EQ(format_reply({false, AxisState::valid, AxisState::valid, 650.0, 1.0}, 600, false), "4 013 OVER +1.00");
  EXPECT_EQ(format_request(Request::stream_start, 20), "c 20\r");
}

TEST(AutocollimatorProtocol, FormatThenParseRoundTrips) {
  std::mt19937 rng(1);
  for (int k = 0; k < 100000; ++k) {
    const Reading r = random_reading(rng);
    const bool ck = rng() % 2 == 0;
    const std::string line = format_reply(r, max_reported_arcsec, ck);
    Reading back;
    ASSERT_EQ(parse_reply(line, ck, back), ParseError::none) << line;
    ASSERT_TRUE(same(r, back)) << line;
  }
}

TEST(AutocollimatorProtocol, FuzzRandomAndMutatedLines) {
  std::mt19937 rng(20261121);
  std::size_t accepted = 0, inputs = 0, checksum_escapes = 0;
  const std::string alphabet = "0123456789+-. *OVER-24ABCDEF\x01\xff";
  for (int k = 0; k < 150000; ++k) {
    std::string line;
    if (k % 3 == 0) {
      const std::size_t n = rng() % 40;
      for (std::size_t i = 0; i < n; ++i) line.push_back(alphabet[rng() % alphabet.size()]);
    } else {
      line = format_reply(random_reading(rng), max_reported_arcsec, k % 3 == 2);
      const std::string original = line;
      switch (rng() % 3) {
        case 0:
          line[rng() % line.size()] = static_cast<char>(rng() % 256);
          break;
        case 1:
          line.erase(rng() % line.size(), 1);
          break;
        default:
          line.insert(rng() % (line.size() + 1), 1, static_cast<char>(rng() % 256));
          break;
      }
      if (k % 3 == 2 && line != original) {
        Reading r;
        // Any single-byte change of a line with a checksum is caught.
        checksum_escapes += parse_reply(line, true, r) == ParseError::none;
      }
    }
    ++inputs;
    Reading r;
    if (parse_reply(line, false, r) == ParseError::none) {
      ++accepted;
      // Anything accepted re-formats to a line that parses to the same reading.
      Reading again;
      ASSERT_EQ(parse_reply(format_reply(r, max_reported_arcsec, false), false, again), ParseError::none) << line;
      ASSERT_TRUE(same(r, again)) << line;
      Sample s;
      reading_to_sample(r, 600.0, s);
      ASSERT_EQ(s.value_count, 2u);
      ASSERT_EQ(s.flags & ~(sample_out_of_range | sample_no_signal), 0u);
      for (int i = 0; i < 2; ++i) ASSERT_EQ(std::isnan(s.value[i]), s.flags != 0 && std::isnan(s.value[i]));
    }
  }
  EXPECT_GE(inputs, 150000u);
  EXPECT_GT(accepted, 1000u);
  EXPECT_EQ(checksum_escapes, 0u);
}

TEST(SerialLineFramer, AnyChunkingGivesTheSameLines) {
  std::mt19937 rng(3);
  for (int k = 0; k < 2000; ++k) {
    std::string stream;
    const int n = static_cast<int>(rng() % 50);
    for (int i = 0; i < n; ++i) {
      const std::size_t len = rng() % 40;
      for (std::size_t j = 0; j < len; ++j) stream.push_back(static_cast<char>('!' + rng() % 90));
      const char* ends[] = {"\r", "\n", "\r\n", "\n\r"};
      stream += ends[rng() % 4];
    }
    drivers::serial::LineFramer whole(30), pieces(30);
    std::vector<std::string> a, b;
    const std::size_t ov_a = whole.feed(stream, a);
    std::size_t ov_b = 0;
    for (std::size_t pos = 0; pos < stream.size();) {
      const std::size_t len = std::min<std::size_t>(1 + rng() % 7, stream.size() - pos);
      ov_b += pieces.feed(std::string_view(stream).substr(pos, len), b);
      pos += len;
    }
    ASSERT_EQ(a, b);
    ASSERT_EQ(ov_a, ov_b);
    for (const auto& l : a) ASSERT_LE(l.size(), 30u);
  }
}
