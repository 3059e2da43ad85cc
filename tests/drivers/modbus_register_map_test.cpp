// The pure register decoder: known encodings, config parsing, and a randomized property test
// (random maps, random and mutated register blocks; >= 200k inputs); the Modbus TCP framing of the
// loop-driven client likewise (the specification's request, every kind of answer, random bytes).
#include "drivers/modbus/modbus_tcp.hpp"
#include "drivers/modbus/register_map.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "core/sample.hpp"

using namespace guideway;
using namespace guideway::drivers::modbus;

namespace {

RegisterMap map_from(const std::string& toml_text) {
  static toml::table table;  // TableReader keeps a pointer
  table = parse_toml(toml_text, "test.toml");
  TableReader reader(table, "test.toml", "device[0].registers");
  RegisterMap m = parse_register_map(reader);
  reader.reject_unknown_keys();
  return m;
}

}  // namespace

TEST(RegisterMap, DecodesInt32BigEndianWithScaleAndStatus) {
  RegisterMap m;  // defaults: input regs, value int32 at 0 (big word order), 0.01 um/count, status at 2
  const std::uint16_t block[] = {0xffff, 0xfc18, 0x0000};  // -1000 counts = -10 um
  const Reading r = decode_registers(m, block);
  ASSERT_TRUE(r.valid);
  EXPECT_EQ(r.flags, 0u);
  EXPECT_DOUBLE_EQ(r.value_m, -10e-6);
  const std::uint16_t over[] = {0x0000, 0x0001, 0x0001};
  const Reading o = decode_registers(m, over);
  EXPECT_EQ(o.flags, std::uint32_t{sample_out_of_range});
  EXPECT_TRUE(std::isnan(o.value_m));
  const std::uint16_t missing[] = {0x0000, 0x0001, 0x0002};
  EXPECT_EQ(decode_registers(m, missing).flags, std::uint32_t{sample_no_signal});
}

TEST(RegisterMap, DecodesFloat32LittleWordOrderAndInt16) {
  const RegisterMap f = map_from(
      "value_type = \"float32\"\nword_order = \"little\"\nscale_um = 1.0\nvalue_address = 10\nstatus_address = -1\n");
  EXPECT_EQ(f.block_start(), 10);
  EXPECT_EQ(f.block_count(), 2);
  // 12.5f = 0x41480000; little word order puts the low word first.
  const std::uint16_t block[] = {0x0000, 0x4148};
  EXPECT_DOUBLE_EQ(decode_registers(f, block).value_m, 12.5e-6);
  const RegisterMap i16 = map_from("value_type = \"int16\"\nscale_um = 0.1\nvalue_address = 5\nstatus_address = 3\n");
  EXPECT_EQ(i16.block_start(), 3);
  EXPECT_EQ(i16.block_count(), 3);
  const std::uint16_t b16[] = {0x0000, 0xbeef, 0xfff6};  // status, unused, -10 counts
  EXPECT_DOUBLE_EQ(decode_registers(i16, b16).value_m, -1e-6);
}

TEST(RegisterMap, RejectsBadConfigWithFileLineAndKey) {
  try {
    map_from("value_type = \"int64\"\n");
    FAIL() << "accepted int64";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("test.toml:1: device[0].registers.value_type"), std::string::npos) << e.what();
  }
  EXPECT_THROW(map_from("value_address = 0\nstatus_address = 1\n"), ConfigError);    // overlaps the int32 value
  EXPECT_THROW(map_from("value_address = 0\nstatus_address = 300\n"), ConfigError);  // > 125 registers apart
  EXPECT_THROW(map_from("scale_um = 0\n"), ConfigError);
  EXPECT_THROW(map_from("wordorder = \"big\"\n"), ConfigError);  // typo caught by reject_unknown_keys
}

TEST(RegisterMap, RandomizedDecodeNeverFailsAndRoundTrips) {
  std::mt19937_64 rng(20261121);
  auto pick = [&](int n) { return static_cast<int>(rng() % static_cast<unsigned>(n)); };
  const ValueType types[] = {ValueType::int16, ValueType::uint16, ValueType::int32, ValueType::uint32,
                             ValueType::float32};
  std::size_t inputs = 0, round_trips = 0;
  for (int iter = 0; iter < 250000; ++iter) {
    RegisterMap m;
    m.function = pick(2) ? RegisterFunction::holding : RegisterFunction::input;
    m.value_type = types[pick(5)];
    m.word_order = pick(2) ? WordOrder::big : WordOrder::little;
    m.value_address = static_cast<std::uint16_t>(pick(4) == 0 ? 65535 - pick(3) : pick(200));
    m.status_address =
        pick(3) == 0 ? std::nullopt : std::optional<std::uint16_t>(static_cast<std::uint16_t>(pick(260)));
    m.scale_um = pick(50) == 0 ? 0.0 : std::ldexp(1.0 + pick(1000) / 1000.0, pick(20) - 12);
    m.offset_um = pick(4) == 0 ? (pick(1000) - 500) * 0.37 : 0.0;
    m.out_of_range_mask = static_cast<std::uint16_t>(rng());
    m.probe_missing_mask = static_cast<std::uint16_t>(rng());
    const bool valid_map = m.validate().empty();
    // A block of random length (sometimes too short), random words.
    const std::size_t base = valid_map && m.block_count() >= 2 ? m.block_count() - 2u : 0u;
    std::vector<std::uint16_t> block(static_cast<std::size_t>(pick(8)) + base);
    for (auto& w : block) w = static_cast<std::uint16_t>(rng());
    const Reading r = decode_registers(m, block);
    ++inputs;
    if (!valid_map || block.size() < m.block_count()) {
      EXPECT_FALSE(r.valid);
      continue;
    }
    ASSERT_TRUE(r.valid);
    if (r.flags == 0) {
      ASSERT_TRUE(std::isfinite(r.value_m));
    } else {
      ASSERT_TRUE(std::isnan(r.value_m));
    }
    // Round trip through the encoder for a status-free value inside the type's range.
    const double counts = m.value_type == ValueType::int16    ? pick(60000) - 30000
                          : m.value_type == ValueType::uint16 ? pick(60000)
                                                              : static_cast<double>(pick(2000000) - 1000000);
    const double counts_ok = (m.value_type == ValueType::uint32 && counts < 0) ? -counts : counts;
    const double value_m = (counts_ok * m.scale_um + m.offset_um) * 1e-6;
    const std::vector<std::uint16_t> enc = encode_registers(m, value_m, 0);
    ASSERT_EQ(enc.size(), m.block_count());
    const Reading back = decode_registers(m, enc);
    ASSERT_TRUE(back.valid);
    ASSERT_EQ(back.flags, 0u);
    const double lsb_m = (m.value_type == ValueType::float32 ? std::abs(value_m) * 1e-6 : m.scale_um * 1e-6);
    ASSERT_NEAR(back.value_m, value_m, lsb_m + 1e-18) << to_string(m.value_type);
    ++round_trips;
  }
  EXPECT_GE(inputs, 250000u);
  EXPECT_GT(round_trips, 100000u);
}

// ---- Modbus TCP framing of the loop-driven client (drivers/modbus/modbus_tcp.hpp).

namespace {

// An answer as a Modbus TCP server frames it: MBAP header, then the PDU.
std::vector<std::uint8_t> tcp_answer(std::uint16_t transaction, std::uint8_t unit,
                                     const std::vector<std::uint8_t>& pdu) {
  const auto length = static_cast<std::uint16_t>(pdu.size() + 1);
  std::vector<std::uint8_t> a;
  const std::uint16_t header[] = {transaction, 0, length};  // big-endian on the wire
  for (const std::uint16_t w : header) {
    a.push_back(static_cast<std::uint8_t>(w >> 8));
    a.push_back(static_cast<std::uint8_t>(w & 0xFF));
  }
  a.push_back(unit);
  for (const std::uint8_t b : pdu) a.push_back(b);
  return a;
}

std::vector<std::uint8_t> registers_pdu(std::uint8_t function, const std::vector<std::uint16_t>& regs) {
  std::vector<std::uint8_t> pdu = {function, static_cast<std::uint8_t>(2 * regs.size())};
  for (const std::uint16_t r : regs) {
    pdu.push_back(static_cast<std::uint8_t>(r >> 8));
    pdu.push_back(static_cast<std::uint8_t>(r));
  }
  return pdu;
}

}  // namespace

TEST(ModbusTcp, TheRequestIsTheSpecificationsFrame) {
  // Modbus Messaging on TCP/IP Implementation Guide: transaction, protocol 0, length 6, unit, then
  // the PDU "read input registers" (FC 4), starting address, quantity.
  const auto r = tcp_read_request(0x1234, 7, RegisterFunction::input, 0x0064, 2);
  const std::array<std::uint8_t, 12> want = {0x12, 0x34, 0, 0, 0, 6, 7, 0x04, 0x00, 0x64, 0x00, 0x02};
  EXPECT_EQ(r, want);
  EXPECT_EQ(tcp_read_request(1, 1, RegisterFunction::holding, 0xFFFE, 125)[7], 0x03);
}

TEST(ModbusTcp, AnswersExceptionsOtherTransactionsAndGarbageAreTold) {
  std::vector<std::uint16_t> out(125);
  const auto ok = tcp_answer(5, 1, registers_pdu(0x04, {0x0001, 0x86A0}));
  auto a = parse_tcp_answer(ok, 5, 1, RegisterFunction::input, 2, out);
  ASSERT_EQ(a.kind, TcpAnswer::Kind::registers);
  EXPECT_EQ(a.length, ok.size());
  EXPECT_EQ(out[0], 0x0001);
  EXPECT_EQ(out[1], 0x86A0);
  // Every prefix is incomplete: the rest is read first.
  for (std::size_t n = 0; n < ok.size(); ++n) {
    EXPECT_EQ(parse_tcp_answer(std::span(ok.data(), n), 5, 1, RegisterFunction::input, 2, out).kind,
              TcpAnswer::Kind::incomplete)
        << n;
  }
  a = parse_tcp_answer(tcp_answer(5, 1, {0x84, 0x06}), 5, 1, RegisterFunction::input, 2, out);
  EXPECT_EQ(a.kind, TcpAnswer::Kind::exception);
  EXPECT_EQ(a.exception_code, 6);
  a = parse_tcp_answer(ok, 4, 1, RegisterFunction::input, 2, out);  // an earlier request's answer
  EXPECT_EQ(a.kind, TcpAnswer::Kind::other_transaction);
  EXPECT_EQ(a.length, ok.size());
  for (const auto& [bytes, words] : std::vector<std::pair<std::vector<std::uint8_t>, std::string>>{
           {tcp_answer(5, 2, registers_pdu(0x04, {1, 2})), "unit 2"},
           {tcp_answer(5, 1, registers_pdu(0x03, {1, 2})), "function code 3"},
           {tcp_answer(5, 1, registers_pdu(0x04, {1, 2, 3})), "6 data bytes to a read of 2"},
           {tcp_answer(5, 1, {0x84, 0x06, 0x00}), "exception response of 3"},
           {{0, 5, 0, 1, 0, 7, 1, 4, 4, 0, 1, 0, 2}, "protocol identifier 1"},
           {{0, 5, 0, 0, 0, 1, 1}, "MBAP length 1"}}) {
    a = parse_tcp_answer(bytes, 5, 1, RegisterFunction::input, 2, out);
    EXPECT_EQ(a.kind, TcpAnswer::Kind::bad) << words;
    EXPECT_NE(a.why.find(words), std::string::npos) << a.why;
  }
}

TEST(ModbusTcp, RandomAndMutatedBytesNeverFailAndRoundTrip) {
  std::mt19937_64 rng(20261127);
  auto pick = [&](int n) { return static_cast<int>(rng() % static_cast<unsigned>(n)); };
  std::vector<std::uint16_t> out(125);
  std::size_t answers = 0;
  for (int iter = 0; iter < 200000; ++iter) {
    const auto count = static_cast<std::uint16_t>(1 + pick(125));
    const auto transaction = static_cast<std::uint16_t>(rng());
    const auto function = pick(2) ? RegisterFunction::holding : RegisterFunction::input;
    std::vector<std::uint16_t> regs(count);
    for (auto& r : regs) r = static_cast<std::uint16_t>(rng());
    std::vector<std::uint8_t> bytes =
        tcp_answer(transaction, 1, registers_pdu(function == RegisterFunction::holding ? 0x03 : 0x04, regs));
    const int mutation = pick(4);
    if (mutation == 1) {  // a few bytes flipped
      for (int k = 0; k < 1 + pick(3); ++k)
        bytes[static_cast<std::size_t>(pick(static_cast<int>(bytes.size())))] ^=
            static_cast<std::uint8_t>(1 + pick(255));
    } else if (mutation == 2) {  // cut or extended
      bytes.resize(static_cast<std::size_t>(pick(static_cast<int>(bytes.size()) + 20)),
                   static_cast<std::uint8_t>(rng()));
    } else if (mutation == 3) {  // random bytes
      bytes.resize(static_cast<std::size_t>(pick(300)));
      for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
    }
    const TcpAnswer a = parse_tcp_answer(bytes, transaction, 1, function, count, out);
    ASSERT_LE(a.length, bytes.size());
    if (a.kind == TcpAnswer::Kind::registers) {
      ASSERT_EQ(a.length, 9u + 2u * count);
      if (mutation == 0) {
        for (std::size_t i = 0; i < count; ++i) ASSERT_EQ(out[i], regs[i]);
        ++answers;
      }
    } else {
      ASSERT_NE(mutation, 0) << "an intact answer is always taken";
    }
  }
  EXPECT_GT(answers, 40000u);
}
