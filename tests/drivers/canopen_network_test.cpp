// The CANopen services (drivers/can/canopen) and the dbb-can network management
// (drivers/dbb/dbb_network), pure: frames written here byte by byte from the CiA 301 facts (not by the
// code under test, nor by the emulator), the network's answers checked byte by byte, its events and
// health read; then random and mutated frames and times against its invariants.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "drivers/can/canopen.hpp"
#include "drivers/dbb/dbb_network.hpp"

using namespace guideway;
using namespace guideway::drivers::dbb;
namespace can = guideway::drivers::can;

namespace {

can_frame frame(canid_t id, std::initializer_list<std::uint8_t> bytes) {
  can_frame f{};
  f.can_id = id;
  f.can_dlc = static_cast<std::uint8_t>(bytes.size());
  std::copy(bytes.begin(), bytes.end(), f.data);
  return f;
}

std::vector<std::uint8_t> bytes_of(const can_frame& f) { return {f.data, f.data + f.can_dlc}; }

std::vector<EncoderScale> encoders() {
  return {{"bar_length", 1, 1e-7, +1, 0, 0.1}, {"x", 2, 1e-7, +1, 0, 0.0}, {"y", 3, 5e-8, -1, 0, 0.0}};
}

constexpr std::int64_t ms = 1'000'000;

// The identity and objects of one well-behaved node, as its SDO server would answer them.
struct NodeFacts {
  std::uint32_t vendor = 0x0000012E, product = 0x00406001, revision = 0x00020003, serial = 0;
  std::uint32_t resolution_nm = 100;
  std::uint32_t tx_type = 1;
  std::uint32_t heartbeat_ms = 0;
};

// Three nodes that are what encoders() says (the third counts 50 nm).
std::vector<NodeFacts> node_facts() {
  std::vector<NodeFacts> f(3);
  f[2].resolution_nm = 50;
  return f;
}

// Answers every SDO request the network sent, as a CiA 301 server with these facts does (expedited,
// size indicated). Returns how many it answered.
int answer_sdo(EncoderNetwork& net, std::int64_t t, const std::vector<NodeFacts>& facts,
               std::vector<can_frame>* nmt_seen = nullptr) {
  int answered = 0;
  for (int round = 0; round < 50; ++round) {
    std::vector<can_frame> out;
    out.swap(net.outgoing());
    if (out.empty()) break;
    for (const can_frame& f : out) {
      const std::uint32_t id = f.can_id & CAN_SFF_MASK;
      if (id == 0x000) {
        if (nmt_seen) nmt_seen->push_back(f);
        continue;
      }
      EXPECT_GE(id, 0x601u);
      EXPECT_LE(id, 0x67Fu);
      EXPECT_EQ(f.can_dlc, 8);
      const std::uint8_t node = static_cast<std::uint8_t>(id - 0x600);
      const NodeFacts& n = facts.at(node - 1);
      const std::uint16_t index = static_cast<std::uint16_t>(f.data[1] | f.data[2] << 8);
      const std::uint8_t sub = f.data[3];
      const canid_t reply = 0x580 + node;
      const auto upload = [&](std::uint32_t v, std::uint8_t size) {
        // 0x43/0x47/0x4B/0x4F: expedited, size indicated, n = 4 - size unused bytes.
        const auto cmd = static_cast<std::uint8_t>(0x43 | (4 - size) << 2);
        net.on_frame(frame(reply, {cmd, f.data[1], f.data[2], sub, static_cast<std::uint8_t>(v),
                                   static_cast<std::uint8_t>(v >> 8), static_cast<std::uint8_t>(v >> 16),
                                   static_cast<std::uint8_t>(v >> 24)}),
                     t);
      };
      ++answered;
      if (f.data[0] == 0x40) {  // initiate upload request
        if (index == 0x1018 && sub == 1)
          upload(n.vendor, 4);
        else if (index == 0x1018 && sub == 2)
          upload(n.product, 4);
        else if (index == 0x1018 && sub == 3)
          upload(n.revision, 4);
        else if (index == 0x1018 && sub == 4)
          upload(n.serial ? n.serial : 1000u + node, 4);
        else if (index == 0x6005 && sub == 1)
          upload(n.resolution_nm, 4);
        else if (index == 0x1800 && sub == 1)
          upload(0x180u + node, 4);
        else if (index == 0x1800 && sub == 2)
          upload(n.tx_type, 1);
        else if (index == 0x1017 && sub == 0)
          upload(n.heartbeat_ms, 2);
        else
          ADD_FAILURE() << "unexpected upload of " << std::hex << index << ":" << int(sub);
      } else if ((f.data[0] & 0xE0) == 0x20) {  // initiate download request, expedited
        const std::uint32_t v =
            f.data[4] | f.data[5] << 8 | f.data[6] << 16 | static_cast<std::uint32_t>(f.data[7]) << 24;
        auto& mutable_facts = const_cast<NodeFacts&>(n);
        if (index == 0x1800 && sub == 2) {
          EXPECT_EQ(f.data[0], 0x2F) << "one byte, size indicated";
          mutable_facts.tx_type = v & 0xFF;
        } else if (index == 0x1017 && sub == 0) {
          EXPECT_EQ(f.data[0], 0x2B) << "two bytes, size indicated";
          mutable_facts.heartbeat_ms = v & 0xFFFF;
        } else {
          ADD_FAILURE() << "unexpected download to " << std::hex << index << ":" << int(sub);
        }
        net.on_frame(frame(reply, {0x60, f.data[1], f.data[2], sub, 0, 0, 0, 0}), t);
      } else {
        ADD_FAILURE() << "unexpected SDO command byte " << int(f.data[0]);
      }
    }
  }
  return answered;
}

std::vector<std::string> event_names(EncoderNetwork& net) {
  std::vector<std::string> out;
  for (const auto& e : net.events()) out.push_back(e.event);
  return out;
}

std::string all_reasons(EncoderNetwork& net) {
  std::string out;
  for (const auto& e : net.events()) out += e.event + ": " + e.reason + "\n";
  return out;
}

bool is_nmt_start(const can_frame& f, std::uint8_t node) {
  return f.can_id == 0x000 && bytes_of(f) == std::vector<std::uint8_t>{0x01, node};
}

}  // namespace

TEST(CanopenFrames, AreTheBytesOfCia301) {
  EXPECT_EQ(bytes_of(can::make_nmt_command(can::NmtCommand::start, 5)), (std::vector<std::uint8_t>{0x01, 0x05}));
  EXPECT_EQ(can::make_nmt_command(can::NmtCommand::reset_node, 0).can_id, 0x000u);
  EXPECT_EQ(bytes_of(can::make_nmt_command(can::NmtCommand::enter_pre_operational, 127)),
            (std::vector<std::uint8_t>{0x80, 0x7F}));
  const can_frame boot = can::make_heartbeat(3, can::NmtState::boot_up);
  EXPECT_EQ(boot.can_id, 0x703u);
  EXPECT_EQ(bytes_of(boot), std::vector<std::uint8_t>{0x00});
  EXPECT_EQ(bytes_of(can::make_heartbeat(3, can::NmtState::pre_operational)), std::vector<std::uint8_t>{0x7F});
  EXPECT_EQ(bytes_of(can::make_heartbeat(3, can::NmtState::operational)), std::vector<std::uint8_t>{0x05});

  const can_frame up = can::make_sdo_upload_request(1, {0x1018, 4});
  EXPECT_EQ(up.can_id, 0x601u);
  EXPECT_EQ(bytes_of(up), (std::vector<std::uint8_t>{0x40, 0x18, 0x10, 0x04, 0, 0, 0, 0}));
  const can_frame down = can::make_sdo_download_request(2, {0x1800, 2}, 1, 1);
  EXPECT_EQ(down.can_id, 0x602u);
  EXPECT_EQ(bytes_of(down), (std::vector<std::uint8_t>{0x2F, 0x00, 0x18, 0x02, 0x01, 0, 0, 0}));
  EXPECT_EQ(bytes_of(can::make_sdo_download_request(2, {0x1017, 0}, 100, 2)),
            (std::vector<std::uint8_t>{0x2B, 0x17, 0x10, 0x00, 100, 0, 0, 0}));
  EXPECT_EQ(bytes_of(can::make_sdo_abort(4, {0x6005, 1}, 0x06020000, false)),
            (std::vector<std::uint8_t>{0x80, 0x05, 0x60, 0x01, 0x00, 0x00, 0x02, 0x06}));
  EXPECT_EQ(can::make_sdo_abort(4, {0x6005, 1}, 0x06020000, false).can_id, 0x584u);
  EXPECT_EQ(can::make_sdo_abort(4, {0x6005, 1}, 0x06020000, true).can_id, 0x604u);

  const can_frame emcy = can::make_emcy(9, {0x8130, 0x11, {1, 2, 3, 4, 5}});
  EXPECT_EQ(emcy.can_id, 0x089u);
  EXPECT_EQ(bytes_of(emcy), (std::vector<std::uint8_t>{0x30, 0x81, 0x11, 1, 2, 3, 4, 5}));
}

TEST(CanopenFrames, ParsesResponsesAsCia301DefinesThem) {
  // Expedited upload responses: 0x43 four bytes, 0x47 three, 0x4B two, 0x4F one, 0x42 size not indicated.
  auto r = can::parse_sdo_response(frame(0x582, {0x43, 0x18, 0x10, 0x01, 0x78, 0x56, 0x34, 0x12}));
  EXPECT_EQ(r.kind, can::SdoKind::upload_response);
  EXPECT_EQ(r.node, 2);
  EXPECT_EQ(r.address.index, 0x1018);
  EXPECT_EQ(r.address.sub, 1);
  EXPECT_EQ(r.value, 0x12345678u);
  EXPECT_EQ(r.size, 4);
  r = can::parse_sdo_response(frame(0x582, {0x4F, 0x00, 0x18, 0x02, 0xFE, 0xAA, 0xBB, 0xCC}));
  EXPECT_EQ(r.value, 0xFEu) << "the bytes beyond the size are not data";
  EXPECT_EQ(r.size, 1);
  r = can::parse_sdo_response(frame(0x582, {0x4B, 0x17, 0x10, 0x00, 0x64, 0x00, 0xEE, 0xEE}));
  EXPECT_EQ(r.value, 100u);
  EXPECT_EQ(r.size, 2);
  r = can::parse_sdo_response(frame(0x582, {0x47, 0x17, 0x10, 0x00, 1, 2, 3, 9}));
  EXPECT_EQ(r.value, 0x030201u);
  r = can::parse_sdo_response(frame(0x582, {0x42, 0x17, 0x10, 0x00, 1, 2, 3, 4}));
  EXPECT_EQ(r.size, 0);
  EXPECT_EQ(r.value, 0x04030201u);
  r = can::parse_sdo_response(frame(0x582, {0x60, 0x00, 0x18, 0x02, 0, 0, 0, 0}));
  EXPECT_EQ(r.kind, can::SdoKind::download_response);
  r = can::parse_sdo_response(frame(0x582, {0x80, 0x18, 0x10, 0x04, 0x11, 0x00, 0x09, 0x06}));
  EXPECT_EQ(r.kind, can::SdoKind::abort);
  EXPECT_EQ(r.abort_code, 0x06090011u);
  EXPECT_EQ(can::sdo_abort_text(r.abort_code), "sub-index does not exist");
  EXPECT_EQ(can::sdo_abort_text(0x08000022),
            "data cannot be transferred or stored to the application because of the present device state");
  EXPECT_EQ(can::sdo_abort_text(0x12345678), "unknown abort code");
  // A segmented upload (e = 0, size in the data) and block transfers are valid, but not served here.
  EXPECT_EQ(can::parse_sdo_response(frame(0x582, {0x41, 0x08, 0x10, 0x00, 20, 0, 0, 0})).kind,
            can::SdoKind::unsupported);
  EXPECT_EQ(can::parse_sdo_response(frame(0x582, {0xC4, 0, 0, 0, 0, 0, 0, 0})).kind, can::SdoKind::unsupported);
  EXPECT_EQ(can::parse_sdo_response(frame(0x582, {0xE0, 0, 0, 0, 0, 0, 0, 0})).kind, can::SdoKind::bad);
  EXPECT_EQ(can::parse_sdo_response(frame(0x582, {0x43, 0x18, 0x10})).kind, can::SdoKind::bad) << "DLC 3";
  EXPECT_EQ(can::parse_sdo_response(frame(0x580, {0x43, 0, 0, 0, 0, 0, 0, 0})).kind, can::SdoKind::bad) << "node 0";

  auto q = can::parse_sdo_request(frame(0x603, {0x23, 0x17, 0x10, 0x00, 0xE8, 0x03, 0, 0}));
  EXPECT_EQ(q.kind, can::SdoKind::download_request);
  EXPECT_EQ(q.value, 1000u);
  EXPECT_EQ(q.size, 4);
  EXPECT_EQ(can::parse_sdo_request(frame(0x603, {0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0})).kind,
            can::SdoKind::upload_request);
  EXPECT_EQ(can::parse_sdo_request(frame(0x603, {0x21, 0x08, 0x10, 0x00, 9, 0, 0, 0})).kind, can::SdoKind::unsupported);

  can::Heartbeat h;
  EXPECT_TRUE(can::parse_heartbeat(frame(0x705, {0x05}), h));
  EXPECT_EQ(h.node, 5);
  EXPECT_EQ(h.state, can::NmtState::operational);
  EXPECT_TRUE(can::parse_heartbeat(frame(0x705, {0x7F}), h));
  EXPECT_EQ(h.state, can::NmtState::pre_operational);
  EXPECT_TRUE(can::parse_heartbeat(frame(0x705, {0x84}), h)) << "node guarding answer, toggle bit set";
  EXPECT_EQ(h.state, can::NmtState::stopped);
  EXPECT_FALSE(can::parse_heartbeat(frame(0x705, {0x03}), h)) << "no such state";
  EXPECT_FALSE(can::parse_heartbeat(frame(0x705, {0x05, 0x00}), h)) << "DLC 2";
  EXPECT_FALSE(can::parse_heartbeat(frame(0x700, {0x05}), h)) << "node 0";

  std::uint8_t node = 0;
  can::Emcy e;
  ASSERT_TRUE(can::parse_emcy(frame(0x083, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0}), node, e));
  EXPECT_EQ(node, 3);
  EXPECT_EQ(e.error_code, 0x8130);
  EXPECT_EQ(can::describe(e),
            "EMCY 0x8130 (life guard or heartbeat error), error register 0x11 (generic, communication)");
  EXPECT_EQ(can::emcy_error_text(0x0000), "error reset or no error");
  EXPECT_EQ(can::emcy_error_text(0x4210), "device temperature");
  EXPECT_EQ(can::emcy_error_text(0x2310), "current, device output side");
  EXPECT_EQ(can::emcy_error_text(0xFF42), "device specific");
  EXPECT_EQ(can::emcy_error_text(0x5530), "device hardware");
  EXPECT_FALSE(can::parse_emcy(frame(0x083, {0x30}), node, e)) << "one byte cannot carry an error code";
  EXPECT_FALSE(can::parse_emcy(frame(0x080, {0, 0, 0, 0, 0, 0, 0, 0}), node, e)) << "SYNC's COB-ID";
}

TEST(EncoderNetwork, ChecksEveryNodeBySdoThenStartsThemTogether) {
  NetworkSettings s;
  s.heartbeat_ms = 50;
  std::vector<NodeExpectation> x(3);
  for (auto& e : x) e.heartbeat_timeout_ms = 150;
  x[1].serial_number = 1002;
  x[1].vendor_id = 0x0000012E;
  EncoderNetwork net(encoders(), x, s);
  auto facts = node_facts();
  for (auto& f : facts) f.heartbeat_ms = 50;
  net.connected(0);
  EXPECT_EQ(net.health().level, NetworkHealth::Level::starting);
  EXPECT_NE(net.health().reason.find("node 1 (bar_length): checking it by SDO"), std::string::npos)
      << net.health().reason;
  // The first requests: identity vendor-ID of every node, in parallel.
  ASSERT_EQ(net.outgoing().size(), 3u);
  EXPECT_EQ(net.outgoing()[0].can_id, 0x601u);
  EXPECT_EQ(bytes_of(net.outgoing()[2]), (std::vector<std::uint8_t>{0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0}));
  std::vector<can_frame> nmt;
  // 8 reads per node: identity x4, resolution, TPDO1 COB-ID and type, heartbeat time.
  EXPECT_EQ(answer_sdo(net, 1 * ms, facts, &nmt), 24);
  ASSERT_EQ(nmt.size(), 3u) << "one NMT start per node, none for the whole bus";
  for (std::uint8_t n = 1; n <= 3; ++n) EXPECT_TRUE(is_nmt_start(nmt[n - 1], n));
  EXPECT_EQ(event_names(net), std::vector<std::string>(3, "node_checked"));
  EXPECT_NE(net.events()[1].reason.find("serial number 1002"), std::string::npos) << net.events()[1].reason;
  EXPECT_NE(net.events()[1].reason.find("vendor-ID 0x0000012E"), std::string::npos) << net.events()[1].reason;
  EXPECT_FALSE(net.events()[0].warning);
  EXPECT_EQ(net.identity(1).serial_number, 1002u);
  EXPECT_EQ(net.counters().nmt_starts, 3u);
  EXPECT_EQ(net.health().level, NetworkHealth::Level::starting);
  EXPECT_NE(net.health().reason.find("started (NMT), waiting for its PDOs"), std::string::npos);
  net.on_cycle(0b111, 2 * ms);
  EXPECT_EQ(net.health().level, NetworkHealth::Level::ok);
  EXPECT_EQ(net.health().reason, "");
  EXPECT_FALSE(net.take_gap()) << "the first PDOs are no recovery";
}

TEST(EncoderNetwork, ANodeOfTheWrongIdentityIsNamedNotStartedAndCheckedAgain) {
  NetworkSettings s;
  s.node_retry_ms = 300;
  std::vector<NodeExpectation> x(3);
  x[1].serial_number = 2002;
  EncoderNetwork net(encoders(), x, s);
  auto facts = node_facts();
  net.connected(0);
  std::vector<can_frame> nmt;
  answer_sdo(net, 1 * ms, facts, &nmt);
  ASSERT_EQ(nmt.size(), 2u) << "nodes 1 and 3 start, node 2 does not";
  EXPECT_TRUE(is_nmt_start(nmt[0], 1));
  EXPECT_TRUE(is_nmt_start(nmt[1], 3));
  const auto& events = net.events();
  const auto failed =
      std::find_if(events.begin(), events.end(), [](const auto& e) { return e.event == "node_check_failed"; });
  ASSERT_NE(failed, events.end()) << all_reasons(net);
  EXPECT_EQ(failed->reason,
            "node 2 (x): 0x1018:4 (identity: serial number) is 1002, configured serial_number = 2002: not the node "
            "this encoder table describes (not started; checked again in 300 ms)");
  EXPECT_TRUE(failed->warning);
  net.events().clear();
  net.on_cycle(0b101, 2 * ms);
  EXPECT_EQ(net.health().level, NetworkHealth::Level::failed);
  EXPECT_EQ(net.health().reason.rfind("node 2 (x): 0x1018:4", 0), 0u) << net.health().reason;
  // Checked again after node_retry_ms; the right node is there now.
  net.tick(200 * ms);
  EXPECT_TRUE(net.outgoing().empty());
  facts[1].serial = 2002;
  net.tick(302 * ms);
  nmt.clear();
  answer_sdo(net, 303 * ms, facts, &nmt);
  ASSERT_EQ(nmt.size(), 1u);
  EXPECT_TRUE(is_nmt_start(nmt[0], 2));
  net.on_cycle(0b111, 310 * ms);
  EXPECT_EQ(net.health().level, NetworkHealth::Level::ok) << net.health().reason;
}

TEST(EncoderNetwork, AbortsAndSilenceAreReportedInWordsNamingNodeAndObject) {
  NetworkSettings s;
  s.sdo_timeout_ms = 100;
  EncoderNetwork net(encoders(), {}, s);
  net.connected(0);
  auto out = std::exchange(net.outgoing(), {});
  ASSERT_EQ(out.size(), 3u);
  // Node 1 aborts: the present device state does not allow it.
  net.on_frame(frame(0x581, {0x80, 0x18, 0x10, 0x01, 0x22, 0x00, 0x00, 0x08}), 1 * ms);
  // Node 2 answers the vendor-ID, then aborts the optional product code: that is fine.
  net.on_frame(frame(0x582, {0x43, 0x18, 0x10, 0x01, 1, 0, 0, 0}), 1 * ms);
  out = std::exchange(net.outgoing(), {});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(bytes_of(out[0]), (std::vector<std::uint8_t>{0x40, 0x18, 0x10, 0x02, 0, 0, 0, 0}));
  net.on_frame(frame(0x582, {0x80, 0x18, 0x10, 0x02, 0x11, 0x00, 0x09, 0x06}), 2 * ms);
  out = std::exchange(net.outgoing(), {});
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].data[3], 3) << "on to the revision number";
  // An answer for another object (a stale one) is not taken for the pending request.
  net.on_frame(frame(0x582, {0x43, 0x18, 0x10, 0x01, 1, 0, 0, 0}), 3 * ms);
  EXPECT_TRUE(net.outgoing().empty());
  // Node 3 says nothing: the request goes once more, then the check fails.
  net.tick(99 * ms);
  EXPECT_TRUE(net.outgoing().empty());
  net.tick(103 * ms);
  out = std::exchange(net.outgoing(), {});
  ASSERT_EQ(out.size(), 2u) << "node 2's revision request and node 3's vendor-ID request were repeated";
  net.tick(202 * ms);
  EXPECT_TRUE(net.outgoing().empty());
  net.tick(204 * ms);
  std::string text = all_reasons(net);
  EXPECT_NE(text.find("node 1 (bar_length): SDO upload of 0x1018:1 (identity: vendor-ID) aborted by the node: "
                      "0x08000022 data cannot be transferred or stored to the application because of the present "
                      "device state"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("node 3 (y): no answer to the SDO upload of 0x1018:1 (identity: vendor-ID) within 100 ms, twice"),
            std::string::npos)
      << text;
  EXPECT_EQ(net.counters().sdo_aborts, 2u);
  EXPECT_EQ(net.counters().sdo_timeouts, 4u);
  EXPECT_EQ(net.health().level, NetworkHealth::Level::failed);
}

TEST(EncoderNetwork, TransmissionTypeIsVerifiedAlwaysAndWrittenOnlyWhenAllowed) {
  auto facts = node_facts();
  facts[2].tx_type = 254;
  {
    EncoderNetwork net(encoders(), {}, NetworkSettings{});
    net.connected(0);
    std::vector<can_frame> nmt;
    answer_sdo(net, 1 * ms, facts, &nmt);
    EXPECT_EQ(nmt.size(), 2u);
    EXPECT_NE(all_reasons(net).find("node 3 (y): 0x1800:2 (TPDO1 transmission type) is 254 (event-driven), needs 1 "
                                    "(synchronous, every SYNC): set it on the node or allow configure_nodes = true"),
              std::string::npos)
        << all_reasons(net);
    EXPECT_EQ(facts[2].tx_type, 254u) << "nothing written";
  }
  NetworkSettings s;
  s.configure_nodes = true;
  s.heartbeat_ms = 20;
  EncoderNetwork net(encoders(), {}, s);
  net.connected(0);
  std::vector<can_frame> nmt;
  answer_sdo(net, 1 * ms, facts, &nmt);
  EXPECT_EQ(nmt.size(), 3u) << all_reasons(net);
  EXPECT_EQ(facts[2].tx_type, 1u) << "written (0x2F 00 18 02 01) and read back";
  for (const auto& f : facts) EXPECT_EQ(f.heartbeat_ms, 20u);
  EXPECT_NE(all_reasons(net).find("TPDO1 transmission type was 254, set to 1 by Guideway"), std::string::npos)
      << all_reasons(net);
}

TEST(EncoderNetwork, BootUpHeartbeatLossPdoSilenceAndEmcyAreNamedAndRecovered) {
  NetworkSettings s;
  s.pdo_timeout_ms = 500;
  std::vector<NodeExpectation> x(3);
  for (auto& e : x) e.heartbeat_timeout_ms = 150;
  EncoderNetwork net(encoders(), x, s);
  auto facts = node_facts();
  net.connected(0);
  answer_sdo(net, 1 * ms, facts);
  std::int64_t t = 2 * ms;
  const auto beat = [&](std::uint8_t node, std::uint8_t state) { net.on_frame(frame(0x700 + node, {state}), t); };
  for (; t < 100 * ms; t += 10 * ms) {
    net.on_cycle(0b111, t);
    if (t % (50 * ms) == 2 * ms) beat(1, 5), beat(2, 5), beat(3, 5);
  }
  EXPECT_EQ(net.health().level, NetworkHealth::Level::ok) << net.health().reason;
  net.events().clear();

  // Node 3 reboots: boot-up (0x703 00), pre-operational; checked and started alone at once.
  beat(3, 0x00);
  EXPECT_EQ(event_names(net), std::vector<std::string>{"node_boot"});
  EXPECT_EQ(net.events()[0].reason,
            "node 3 (y) booted (boot-up message): pre-operational, no PDOs until started; checking it by SDO and "
            "starting it");
  EXPECT_EQ(net.health().level, NetworkHealth::Level::starting);
  EXPECT_EQ(net.health().reason, "node 3 (y) rebooted: checking it by SDO");
  std::vector<can_frame> nmt;
  answer_sdo(net, t, facts, &nmt);
  ASSERT_EQ(nmt.size(), 1u);
  EXPECT_TRUE(is_nmt_start(nmt[0], 3));
  net.on_cycle(0b011, t += 10 * ms);
  net.on_cycle(0b111, t += 10 * ms);
  EXPECT_TRUE(net.take_gap()) << "its first PDO after the reboot";
  EXPECT_EQ(net.health().level, NetworkHealth::Level::ok);
  EXPECT_EQ(net.events().back().event, "node_back");
  EXPECT_EQ(net.counters().boot_ups, 1u);
  net.events().clear();

  // Node 2 falls silent (heartbeat and PDOs): named after 3 cycles, its heartbeat later.
  const std::int64_t last_beat = t;
  beat(1, 5), beat(2, 5), beat(3, 5);
  for (int k = 0; k < 3; ++k) net.on_cycle(0b101, t += 10 * ms);
  EXPECT_EQ(net.health().level, NetworkHealth::Level::lost);
  EXPECT_EQ(net.health().reason,
            "node 2 (x): no PDO in the last 3 cycles (its channel holds its last value; samples are flagged partial)");
  for (; t < last_beat + 170 * ms; t += 10 * ms) {
    net.on_cycle(0b101, t);
    if ((t - last_beat) % (50 * ms) == 0) beat(1, 5), beat(3, 5);
    net.tick(t);
  }
  EXPECT_EQ(net.health().reason, "node 2 (x): no heartbeat for 150 ms");
  EXPECT_EQ(net.counters().heartbeat_timeouts, 1u);
  // It comes back where it was (a connector): heartbeat, PDOs, and an EMCY saying why.
  net.on_frame(frame(0x082, {0x40, 0x81, 0x11, 0, 0, 0, 0, 0}), t);
  beat(2, 5);
  EXPECT_EQ(net.health().level, NetworkHealth::Level::lost) << "its PDOs are still missing";
  net.on_cycle(0b111, t += 10 * ms);
  EXPECT_EQ(net.health().level, NetworkHealth::Level::ok);
  EXPECT_TRUE(net.take_gap());
  const auto names = event_names(net);
  EXPECT_EQ(names, (std::vector<std::string>{"node_lost", "node_lost", "node_emcy", "node_back"})) << all_reasons(net);
  EXPECT_EQ(net.events()[2].reason,
            "node 2 (x): EMCY 0x8140 (recovered from bus off), error register 0x11 (generic, communication)");
  EXPECT_TRUE(net.events()[2].warning);
  net.events().clear();
  net.on_frame(frame(0x082, {0x00, 0x00, 0x00, 0, 0, 0, 0, 0}), t);
  ASSERT_EQ(net.events().size(), 1u);
  EXPECT_FALSE(net.events()[0].warning) << "an error reset is news, not a warning";
  EXPECT_EQ(net.counters().emcys, 2u);
}

TEST(EncoderNetwork, WhenTheControllerManagesNmtNothingIsSentAndNodesWait) {
  NetworkSettings s;
  s.manage_nmt = false;
  s.sdo_checks = false;
  EncoderNetwork net(encoders(), {}, s);
  net.connected(0);
  EXPECT_TRUE(net.outgoing().empty());
  EXPECT_EQ(net.health().level, NetworkHealth::Level::starting);
  net.on_frame(frame(0x701, {0x7F}), 1 * ms);
  net.on_frame(frame(0x702, {0x05}), 1 * ms);
  EXPECT_NE(net.health().reason.find("node 1 (bar_length): pre-operational, waiting for the NMT master to start it"),
            std::string::npos)
      << net.health().reason;
  net.on_frame(frame(0x703, {0x00}), 2 * ms);  // a boot-up: reported, still nothing sent
  EXPECT_TRUE(net.outgoing().empty());
  EXPECT_EQ(net.events().back().reason,
            "node 3 (y) booted (boot-up message): no PDOs until the NMT master (or the node itself) starts it");
  net.on_cycle(0b111, 10 * ms);  // the controller started them: PDOs
  EXPECT_EQ(net.health().level, NetworkHealth::Level::ok);
  EXPECT_TRUE(net.outgoing().empty());
}

TEST(EncoderNetwork, ANodeStoppedByAnotherMasterOrBackInPreOperationalIsNamedAndRestarted) {
  EncoderNetwork net(encoders(), {}, NetworkSettings{});
  auto facts = node_facts();
  net.connected(0);
  answer_sdo(net, 1 * ms, facts);
  net.on_cycle(0b111, 10 * ms);
  net.on_frame(frame(0x701, {0x04}), 11 * ms);
  EXPECT_EQ(net.health().reason, "node 1 (bar_length) stopped by an NMT command: it sends no PDOs");
  EXPECT_TRUE(net.outgoing().empty()) << "another master stopped it: not fought";
  net.on_frame(frame(0x702, {0x7F}), 12 * ms);
  EXPECT_EQ(net.events().back().reason,
            "node 2 (x) is pre-operational again (heartbeat): it sends no PDOs; starting it again");
  std::vector<can_frame> nmt;
  answer_sdo(net, 13 * ms, facts, &nmt);
  ASSERT_EQ(nmt.size(), 1u);
  EXPECT_TRUE(is_nmt_start(nmt[0], 2));
}

// Random frames on every COB-ID of the network services and the PDOs, random times: nothing crashes,
// every frame the network sends is a well-formed NMT start or SDO request to a configured node, and the
// health says why whenever it is not ok.
TEST(EncoderNetwork, FuzzedFramesKeepItsInvariants) {
  std::mt19937 rng(2024);
  std::uniform_int_distribution<int> byte(0, 255);
  for (const bool manage : {true, false}) {
    NetworkSettings s;
    s.manage_nmt = manage;
    s.sdo_checks = true;
    s.configure_nodes = manage;
    s.heartbeat_ms = 10;
    s.node_retry_ms = 50;
    std::vector<NodeExpectation> x(3);
    for (auto& e : x) e.heartbeat_timeout_ms = 30;
    x[0].serial_number = 1001;
    EncoderNetwork net(encoders(), x, s);
    net.connected(0);
    std::int64_t t = 0;
    const std::uint32_t bases[] = {0x000, 0x080, 0x180, 0x580, 0x600, 0x700};
    for (int k = 0; k < 100000; ++k) {
      can_frame f{};
      const int kind = byte(rng) % 8;
      if (kind < 6) {
        f.can_id = bases[kind] + static_cast<std::uint32_t>(byte(rng) % 5);
      } else {
        f.can_id = static_cast<std::uint32_t>(byte(rng) << 3 | byte(rng) % 8) & CAN_SFF_MASK;
        if (byte(rng) < 10) f.can_id |= CAN_RTR_FLAG;
        if (byte(rng) < 10) f.can_id |= CAN_EFF_FLAG;
      }
      f.can_dlc = static_cast<std::uint8_t>(byte(rng) % 10);  // 9 is invalid
      for (auto& b : f.data) b = static_cast<std::uint8_t>(byte(rng));
      if ((f.can_id & 0x780) == 0x580 && byte(rng) < 200) {
        // Mostly plausible SDO answers: a valid command byte for the object being read.
        const std::uint8_t commands[] = {0x43, 0x4F, 0x4B, 0x60, 0x80, 0x41, 0x42};
        f.data[0] = commands[byte(rng) % 7];
        f.can_dlc = 8;
      }
      t += byte(rng) * 20'000;
      (void)net.on_frame(f, t);
      if (byte(rng) < 40) net.on_cycle(static_cast<std::uint32_t>(byte(rng) % 8), t);
      if (byte(rng) < 30) net.tick(t);
      if (byte(rng) < 2) net.connected(t);
      for (const can_frame& o : net.outgoing()) {
        ASSERT_FALSE(o.can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG | CAN_ERR_FLAG));
        if (o.can_id == 0x000) {
          ASSERT_TRUE(manage) << "an NMT command with nmt = listen";
          ASSERT_EQ(o.can_dlc, 2);
          ASSERT_EQ(o.data[0], 0x01);
          ASSERT_TRUE(o.data[1] >= 1 && o.data[1] <= 3) << int(o.data[1]);
        } else {
          ASSERT_TRUE(o.can_id >= 0x601 && o.can_id <= 0x603) << std::hex << o.can_id;
          ASSERT_EQ(o.can_dlc, 8);
          const auto kind_of = can::parse_sdo_request(o).kind;
          ASSERT_TRUE(kind_of == can::SdoKind::upload_request || kind_of == can::SdoKind::download_request ||
                      kind_of == can::SdoKind::abort);
          if (!manage) {
            ASSERT_NE(kind_of, can::SdoKind::download_request) << "configure_nodes is off";
          }
        }
      }
      net.outgoing().clear();
      for (const auto& e : net.events()) ASSERT_EQ(e.reason.rfind("node ", 0), 0u) << e.reason;
      net.events().clear();
      const auto& h = net.health();
      ASSERT_EQ(h.level == NetworkHealth::Level::ok, h.reason.empty()) << h.reason;
    }
  }
}

// The CiA 301 decoders on random bytes: no crash, and what they accept is consistent.
TEST(CanopenFrames, FuzzedBytesNeverCrashTheDecoders) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int k = 0; k < 300000; ++k) {
    can_frame f{};
    f.can_id = static_cast<std::uint32_t>(byte(rng) << 8 | byte(rng)) & 0x7FF;
    if (byte(rng) < 5) f.can_id |= CAN_ERR_FLAG;
    f.can_dlc = static_cast<std::uint8_t>(byte(rng) % 16);
    for (auto& b : f.data) b = static_cast<std::uint8_t>(byte(rng));
    const auto req = can::parse_sdo_request(f);
    const auto res = can::parse_sdo_response(f);
    if (req.kind != can::SdoKind::bad) {
      ASSERT_EQ(f.can_id & 0x780, 0x600u);
    }
    if (res.kind != can::SdoKind::bad) {
      ASSERT_EQ(f.can_id & 0x780, 0x580u);
    }
    if (res.kind == can::SdoKind::upload_response && res.size > 0 && res.size < 4) {
      ASSERT_LT(res.value, 1u << (8 * res.size));
    }
    can::Heartbeat h;
    if (can::parse_heartbeat(f, h)) {
      ASSERT_EQ(0x700u + h.node, f.can_id);
    }
    std::uint8_t node = 0;
    can::Emcy e;
    if (can::parse_emcy(f, node, e)) {
      ASSERT_EQ(0x080u + node, f.can_id);
      ASSERT_FALSE(can::describe(e).empty());
    }
    can::NmtCommand c;
    if (can::parse_nmt_command(f, c, node)) {
      ASSERT_EQ(f.can_id, 0u);
    }
    (void)can::sdo_abort_text(static_cast<std::uint32_t>(byte(rng) << 24 | byte(rng)));
  }
}

// The instrument's serial ([[device]] serial) against what the bar's node reports: a warning that stands
// until a check finds it right, an EVENT per check, never a refusal (docs/configuration.md).
TEST(EncoderNetwork, TheInstrumentsSerialIsComparedWarnedAboutAndNotRefused) {
  NetworkSettings s;
  std::vector<NodeExpectation> x(3);
  x[0].instrument_serial = 1001;
  EncoderNetwork net(encoders(), x, s);
  auto facts = node_facts();
  facts[0].serial = 4242;
  net.connected(0);
  std::vector<can_frame> nmt;
  answer_sdo(net, 1 * ms, facts, &nmt);
  ASSERT_EQ(nmt.size(), 3u) << "every node is started: a serial mismatch is no refusal";
  const auto& events = net.events();
  const auto mismatch =
      std::find_if(events.begin(), events.end(), [](const auto& e) { return e.event == "instrument_serial_mismatch"; });
  ASSERT_NE(mismatch, events.end()) << all_reasons(net);
  EXPECT_EQ(mismatch->reason,
            "node 1 (bar_length) reports serial number 4242 (0x1018:4), the device's serial is 1001: not the "
            "instrument the configuration and its calibration name (measuring anyway; check the instrument or "
            "its serial)");
  EXPECT_TRUE(mismatch->warning);
  ASSERT_EQ(net.warnings().size(), 1u);
  EXPECT_EQ(net.warnings()[0].rfind("node 1 (bar_length) reports serial number 4242", 0), 0u) << net.warnings()[0];
  net.on_cycle(0b111, 2 * ms);
  EXPECT_EQ(net.health().level, NetworkHealth::Level::ok) << net.health().reason;
  // A new connection: the warning stands until the node's check says otherwise; the right node clears it.
  net.events().clear();
  facts[0].serial = 1001;
  const std::uint64_t version = net.health_version();
  net.connected(10 * ms);
  EXPECT_EQ(net.warnings().size(), 1u);
  answer_sdo(net, 11 * ms, facts);
  EXPECT_TRUE(net.warnings().empty());
  EXPECT_GT(net.health_version(), version);
  const std::vector<std::string> names = event_names(net);
  EXPECT_EQ(std::count(names.begin(), names.end(), "instrument_serial_mismatch"), 0) << all_reasons(net);
}
