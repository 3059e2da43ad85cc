// plant/: the MQTT topic tree, broker addresses and the publisher's on-disk journal (its bounds, its
// order of eviction by share, its survival across a restart, files a crash cut short) and the events'
// rate limit. The publisher against a real broker is
// tests/plant/mqtt_daemon_test.py.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <random>

#include "core/printable.hpp"
#include "plant/broker_address.hpp"
#include "plant/event_rate_limit.hpp"
#include "plant/message_journal.hpp"
#include "plant/mqtt_codec.hpp"
#include "plant/topics.hpp"
#include "test_support.hpp"

namespace guideway::plant {
namespace {

using test::TempDir;

TEST(Topics, EveryLeafRoundTrips) {
  EXPECT_EQ(topic_for("guideway", "mill-1", TopicLeaf::params, "dbb"), "guideway/mill-1/params/dbb");
  EXPECT_EQ(topic_for("plant/a", "mill-1", TopicLeaf::status), "plant/a/mill-1/status");
  for (TopicLeaf leaf :
       {TopicLeaf::status, TopicLeaf::params, TopicLeaf::explain, TopicLeaf::event, TopicLeaf::devices}) {
    const auto t = parse_topic("plant/a", topic_for("plant/a", "m", leaf, "runout"));
    ASSERT_TRUE(t) << to_string(leaf);
    EXPECT_EQ(t->machine, "m");
    EXPECT_EQ(t->leaf, leaf);
    EXPECT_EQ(t->kind, leaf == TopicLeaf::params || leaf == TopicLeaf::explain ? "runout" : "");
  }
}

TEST(Topics, TopicsOutsideTheTreeAreNotTakenApart) {
  for (const char* topic :
       {"guideway", "guideway/", "guideway/m", "guideway/m/params", "guideway/m/params/", "guideway/m/status/x",
        "guideway/m/other", "guidewayx/m/status", "other/m/status", "guideway//status", "guideway/m/params/a/b"}) {
    EXPECT_FALSE(parse_topic("guideway", topic)) << topic;
  }
}

TEST(Topics, NamesThatCannotBeALevelAreRefused) {
  EXPECT_EQ(topic_level_problem("mill-1"), "");
  EXPECT_NE(topic_level_problem(""), "");
  EXPECT_NE(topic_level_problem("a/b"), "");
  EXPECT_NE(topic_level_problem("a+"), "");
  EXPECT_NE(topic_level_problem("#"), "");
  EXPECT_EQ(topic_prefix_problem("plant/hall-2"), "");
  EXPECT_NE(topic_prefix_problem("/plant"), "");
  EXPECT_NE(topic_prefix_problem("plant//x"), "");
  EXPECT_NE(topic_prefix_problem(std::string("a\0b", 3)), "");
  // What --check-config passed and the daemon then died on (or printed raw to a terminal).
  EXPECT_NE(topic_level_problem("a\x1b"
                                "b"),
            "");
  EXPECT_NE(topic_level_problem(std::string(70000, 'm')), "");
  EXPECT_NE(topic_level_problem("\xff\xfe"), "");
  EXPECT_EQ(topic_level_problem("Fräse-3"), "");  // UTF-8 is fine
  EXPECT_EQ(client_id_problem("guidewayd-mill-1"), "");
  EXPECT_NE(client_id_problem(std::string(70000, 'c')), "");
  EXPECT_NE(client_id_problem("a\nb"), "");
  EXPECT_NE(client_id_problem(""), "");
}

TEST(Printable, ControlCharactersAndBrokenUtf8BecomeVisible) {
  EXPECT_EQ(guideway::printable("mill-1 µm"), "mill-1 µm");
  EXPECT_EQ(guideway::printable("\x1b[2J\x1b]0;owned\x07"), "\\x1b[2J\\x1b]0;owned\\x07");
  EXPECT_EQ(guideway::printable("\xc2\x9b"
                                "31m"),
            "\\u009b31m");  // C1 CSI
  EXPECT_EQ(guideway::printable("a\xff"
                                "b\x7f"),
            "a\\xffb\\x7f");
  EXPECT_EQ(guideway::printable(std::string("a\0b", 3)), "a\\x00b");
  // Property: the output of any bytes has no control character and is valid UTF-8 (printable of it is itself).
  std::mt19937 rng(7);
  for (int i = 0; i < 2000; ++i) {
    std::string bytes(rng() % 40, '\0');
    for (auto& c : bytes) c = static_cast<char>(rng() & 0xFF);
    const std::string out = guideway::printable(bytes);
    EXPECT_EQ(guideway::printable(out), out);
    for (const char c : out) EXPECT_FALSE(static_cast<unsigned char>(c) < 0x20 || c == 0x7F);
  }
}

TEST(BrokerAddress, SchemesPortsAndHosts) {
  auto a = parse_broker_url("mqtt://broker.plant");
  EXPECT_EQ(a.host, "broker.plant");
  EXPECT_EQ(a.port, 1883);
  EXPECT_FALSE(a.tls);
  a = parse_broker_url("mqtts://10.0.0.5");
  EXPECT_EQ(a.port, 8883);
  EXPECT_TRUE(a.tls);
  a = parse_broker_url("mqtt://127.0.0.1:18830/");
  EXPECT_EQ(a.port, 18830);
  EXPECT_EQ(a.url(), "mqtt://127.0.0.1:18830");
  a = parse_broker_url("mqtts://[::1]:8884");
  EXPECT_EQ(a.host, "::1");
  EXPECT_EQ(a.url(), "mqtts://[::1]:8884");
  for (const char* bad : {"", "broker:1883", "tcp://b", "mqtt://", "mqtt://:1883", "mqtt://b:", "mqtt://b:0",
                          "mqtt://b:65536", "mqtt://b:18x", "mqtt://user:pw@b", "mqtt://b/topic", "mqtts://[::1",
                          "mqtt://::1", "mqtt://bro ker", "mqtt://broker\t", "mqtt://[b.plant]", "mqtt://b\x1b[2J"}) {
    EXPECT_THROW(parse_broker_url(bad), std::invalid_argument) << bad;
  }
  EXPECT_THROW(parse_broker_url(std::string("mqtt://b\0x", 10)), std::invalid_argument);
  try {
    parse_broker_url("mqtt://::1");
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("between brackets"), std::string::npos) << e.what();
  }
  EXPECT_EQ(parse_broker_url("mqtt://[fe80::1%eth0]:1883").host, "fe80::1%eth0");
  EXPECT_EQ(parse_broker_url("mqtt://broker_1.plant-a").host, "broker_1.plant-a");
  try {
    parse_broker_url("http://b");
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("mqtt://HOST[:PORT]"), std::string::npos) << e.what();
  }
}

JournalEntry entry(int i, std::size_t payload_bytes = 10, JournalShare share = JournalShare::results) {
  return {"guideway/m/event", std::to_string(i) + std::string(payload_bytes, 'x'), "2026-11-26T10:00:00.000Z",
          i % 2 == 0, share};
}

// Bounds without a share of their own for events.
JournalBounds bounds(std::size_t messages, std::size_t bytes) { return {messages, bytes, messages, bytes}; }

std::uint64_t total(const JournalDrops& d) { return d[0] + d[1] + d[2]; }

std::vector<std::string> drain(MessageJournal& j) {
  std::vector<std::string> out;
  while (auto e = j.front()) {
    out.push_back(e->payload.substr(0, e->payload.find('x')));
    j.pop_front();
  }
  return out;
}

TEST(MessageJournal, KeepsTheOrderAcrossARestart) {
  TempDir dir;
  const std::string path = dir.file("journal");
  {
    MessageJournal j(path, bounds(100, 1 << 20));
    for (int i = 0; i < 5; ++i) EXPECT_EQ(total(j.push(entry(i))), 0u);
    j.pop_front();
    EXPECT_EQ(j.size(), 4u);
  }
  EXPECT_EQ(std::filesystem::status(path).permissions() & std::filesystem::perms::all,
            std::filesystem::perms::owner_all);
  MessageJournal j(path, bounds(100, 1 << 20));
  EXPECT_EQ(j.taken_up(), 4u);
  j.push(entry(5));
  const auto front = j.front();
  ASSERT_TRUE(front);
  EXPECT_EQ(front->topic, "guideway/m/event");
  EXPECT_EQ(front->produced_utc, "2026-11-26T10:00:00.000Z");
  EXPECT_FALSE(front->retain);  // entry 1
  EXPECT_EQ(drain(j), (std::vector<std::string>{"1", "2", "3", "4", "5"}));
  EXPECT_TRUE(std::filesystem::is_empty(path));
}

TEST(MessageJournal, DropsTheOldestPastItsBoundsAndSaysHowMany) {
  TempDir dir;
  MessageJournal by_count(dir.file("a"), bounds(3, 1 << 20));
  std::size_t dropped = 0;
  for (int i = 0; i < 5; ++i) dropped += total(by_count.push(entry(i)));
  EXPECT_EQ(dropped, 2u);
  EXPECT_EQ(drain(by_count), (std::vector<std::string>{"2", "3", "4"}));

  MessageJournal by_bytes(dir.file("b"), bounds(1000, 1000));
  dropped = 0;
  for (int i = 0; i < 10; ++i) dropped += total(by_bytes.push(entry(i, 300)));
  EXPECT_LE(by_bytes.bytes(), 1000u);
  EXPECT_EQ(dropped + by_bytes.size(), 10u);
  EXPECT_EQ(drain(by_bytes).back(), "9");
  // One message over the byte bound alone is kept: the bound is on the backlog.
  EXPECT_EQ(total(by_bytes.push(entry(10, 5000))), 0u);
  EXPECT_EQ(by_bytes.size(), 1u);
}

// Issue 46 item 2: broker down, queue_max_messages = 100, a session's PARAMS and EXPLAIN, then any number
// of a device's events: the results stay, in their place in the order; the events keep their share.
TEST(MessageJournal, ASessionsResultsSurviveAnyNumberOfEvents) {
  TempDir dir;
  for (const int events : {150, 1000, 20000}) {
    const std::string path = dir.file("j" + std::to_string(events));
    {
      MessageJournal j(path, {100, 1 << 20, 25, 1 << 18});
      j.push(entry(0, 10, JournalShare::transitions));  // the device streaming
      j.push(entry(1, 4000));                           // PARAMS
      j.push(entry(2, 9000));                           // EXPLAIN
      for (int i = 0; i < events; ++i) j.push(entry(3 + i, 40, JournalShare::events));
      EXPECT_EQ(j.dropped(JournalShare::results), 0u);
      EXPECT_EQ(j.dropped(JournalShare::transitions), 0u);
      EXPECT_EQ(j.dropped(JournalShare::events), static_cast<std::uint64_t>(events - 25));
      EXPECT_EQ(j.size(JournalShare::events), 25u);
    }
    MessageJournal j(path, {100, 1 << 20, 25, 1 << 18});  // and so after a restart, shares and all
    EXPECT_EQ(j.size(JournalShare::results), 2u);
    EXPECT_EQ(j.size(JournalShare::transitions), 1u);
    const std::vector<std::string> order = drain(j);
    ASSERT_EQ(order.size(), 28u);
    EXPECT_EQ(std::vector<std::string>(order.begin(), order.begin() + 4),
              (std::vector<std::string>{"0", "1", "2", std::to_string(3 + events - 25)}));
    EXPECT_EQ(order.back(), std::to_string(2 + events));
  }
}

// Property: whatever comes in whatever order under whatever bounds, a message is dropped only for one of
// its own share or when no share evicted before it has a message; the events keep within their share,
// the whole within its bounds, and what is left leaves in the order it came.
TEST(MessageJournal, TheOrderOfEvictionHoldsForAnyMix) {
  TempDir dir;
  std::mt19937 rng(46);
  for (int round = 0; round < 40; ++round) {
    const JournalBounds b{1 + rng() % 30, 200 + rng() % 3000, 1 + rng() % 10, 100 + rng() % 1000};
    MessageJournal j(dir.file("r" + std::to_string(round)), b);
    std::vector<int> expected;  // what is left, in order
    std::vector<JournalShare> share_of;
    for (int i = 0; i < 200; ++i) {
      const auto share = static_cast<JournalShare>(rng() % journal_share_count);
      const std::array<std::size_t, journal_share_count> before = {
          j.size(JournalShare::events), j.size(JournalShare::transitions), j.size(JournalShare::results)};
      const JournalDrops d = j.push(entry(i, rng() % 120, share));
      share_of.push_back(share);
      expected.push_back(i);
      for (std::size_t s = 1; s < journal_share_count; ++s) {
        if (d[s] == 0) continue;  // a later share lost a message: every earlier one was empty but for this push
        for (std::size_t earlier = 0; earlier < s; ++earlier)
          EXPECT_EQ(before[earlier] + (static_cast<std::size_t>(share) == earlier ? 1u : 0u), d[earlier])
              << "round " << round << " message " << i;
      }
      EXPECT_LE(j.size(JournalShare::events), b.max_event_messages);
      if (j.size() > 1) {
        EXPECT_LE(j.size(), b.max_messages);
        EXPECT_LE(j.bytes(), b.max_bytes);
      }
      // Which ones went: the oldest of each share, by the counts.
      for (std::size_t s = 0; s < journal_share_count; ++s) {
        for (std::uint64_t k = 0; k < d[s]; ++k) {
          const auto it = std::find_if(expected.begin(), expected.end(),
                                       [&](int m) { return static_cast<std::size_t>(share_of[m]) == s; });
          ASSERT_NE(it, expected.end());
          expected.erase(it);
        }
      }
    }
    std::vector<std::string> want;
    for (int m : expected) want.push_back(std::to_string(m));
    EXPECT_EQ(drain(j), want) << "round " << round;
  }
}

TEST(EventRateLimit, ABurstThenTheRateEachSourceOnItsOwnAndTheHeldBackCounted) {
  EventRateLimit limit(60);  // a burst of 60, then one a second
  const std::int64_t s = 1'000'000'000;
  int admitted = 0;
  for (int i = 0; i < 150; ++i) admitted += limit.admit("dbb", 10 * s) ? 1 : 0;
  EXPECT_EQ(admitted, 60);
  EXPECT_EQ(limit.held_back_total(), 90u);
  EXPECT_TRUE(limit.admit("autocollimator", 10 * s));  // another device is not held back by this one's flood
  EXPECT_TRUE(limit.take_held_back(10 * s).empty());   // no token left to say it with yet
  EXPECT_FALSE(limit.admit("dbb", 10 * s + s / 2));    // counted, after the held-back ones
  const auto said = limit.take_held_back(11 * s);
  ASSERT_EQ(said.size(), 1u);
  EXPECT_EQ(said[0].source, "dbb");
  EXPECT_EQ(said[0].count, 91u);
  EXPECT_TRUE(limit.take_held_back(11 * s).empty());
  EXPECT_FALSE(limit.admit("dbb", 11 * s));  // the token went to the count
  EXPECT_FALSE(limit.admit("dbb", 12 * s));  // a token, but the count of the one before goes first
  const auto then = limit.take_held_back(12 * s);
  ASSERT_EQ(then.size(), 1u);
  EXPECT_EQ(then[0].count, 2u);
  EXPECT_TRUE(limit.admit("dbb", 13 * s));
  EXPECT_EQ(limit.held_back_total(), 93u);
}

TEST(MessageJournal, AFileACrashCutShortIsSkippedAndCounted) {
  TempDir dir;
  const std::string path = dir.file("journal");
  {
    MessageJournal j(path, bounds(100, 1 << 20));
    for (int i = 0; i < 3; ++i) j.push(entry(i));
  }
  std::vector<std::filesystem::path> files;
  for (const auto& f : std::filesystem::directory_iterator(path)) files.push_back(f.path());
  std::sort(files.begin(), files.end());
  std::filesystem::resize_file(files[1], 20);                     // truncated
  std::ofstream(path + "/00000000000000000009.msg.part") << "x";  // a write cut short
  MessageJournal j(path, bounds(100, 1 << 20));
  EXPECT_EQ(drain(j), (std::vector<std::string>{"0", "2"}));
  EXPECT_EQ(j.unreadable(), 1u);
  EXPECT_FALSE(std::filesystem::exists(path + "/00000000000000000009.msg.part"));
}

TEST(MessageJournal, AnyPayloadRoundTrips) {  // property: every byte string, every flag
  std::mt19937 rng(7);
  for (int n = 0; n < 500; ++n) {
    JournalEntry e;
    e.topic = "guideway/m" + std::to_string(n) + "/params/dbb";
    e.payload.resize(rng() % 300);
    for (char& c : e.payload) c = static_cast<char>(rng() % 256);
    e.produced_utc = n % 7 == 0 ? "" : "2026-11-26T10:00:00.123Z";
    e.retain = rng() % 2 == 0;
    const auto back = decode_journal_entry(encode_journal_entry(e));
    ASSERT_TRUE(back) << n;
    EXPECT_EQ(back->payload, e.payload);
    EXPECT_EQ(back->topic, e.topic);
    EXPECT_EQ(back->produced_utc, e.produced_utc);
    EXPECT_EQ(back->retain, e.retain);
    const std::string text = encode_journal_entry(e);
    EXPECT_FALSE(decode_journal_entry(text.substr(0, rng() % text.size()))) << n;  // any truncation is refused
  }
}

// The fleet's MQTT 5 client: what it sends, byte for byte as the standard lays it out, and what it reads.
TEST(MqttCodec, ConnectSubscribeAndPubackBytes) {
  MqttConnectRequest r;
  r.client_id = "f";
  r.keepalive_s = 30;
  r.session_expiry_s = 604800;
  r.receive_maximum = 100;
  const std::string c = encode_connect(r);
  // CONNECT, remaining length, "MQTT", level 5, flags (clean start 0), keep-alive 30, properties:
  // session expiry (0x11) 604800, receive maximum (0x21) 100; client id "f".
  const std::string expected(
      "\x10\x16\x00\x04MQTT\x05\x00\x00\x1e\x08\x11\x00\x09\x3a\x80\x21\x00\x64\x00\x01"
      "f",
      24);
  EXPECT_EQ(c, expected);
  EXPECT_EQ(encode_subscribe(1, "g/#", 1), std::string("\x82\x09\x00\x01\x00\x00\x03g/#\x01", 11));
  EXPECT_EQ(encode_puback(0x1234), std::string("\x40\x02\x12\x34", 4));
  EXPECT_EQ(encode_pingreq(), std::string("\xc0\x00", 2));
  EXPECT_EQ(encode_disconnect(0), std::string("\xe0\x00", 2));
  r.username = "u";
  r.password = "p";
  EXPECT_EQ(static_cast<unsigned char>(encode_connect(r)[9]), 0xC0u);  // username and password flags
}

TEST(MqttCodec, PublishRoundTripsThroughThePacketReader) {
  MqttPublish p;
  p.topic = "guideway/mill-1/params/dbb";
  p.qos = 1;
  p.packet_id = 513;
  p.dup = true;
  p.user_properties = {{"produced_utc", "2026-11-26T10:00:00.000Z"}, {"x", "y"}};
  p.payload = std::string(300, 'j');  // a remaining length of two bytes
  const std::string bytes = encode_publish(p) + encode_connack(true, 0) + "\xd0";
  MqttPacketReader reader(1 << 20);
  for (const char c : bytes) reader.feed(std::string_view(&c, 1));  // one byte at a time
  const auto a = reader.next();
  ASSERT_TRUE(a);
  const auto q = decode_publish(*a);
  EXPECT_EQ(q.topic, p.topic);
  EXPECT_EQ(q.qos, 1);
  EXPECT_TRUE(q.dup);
  EXPECT_EQ(q.packet_id, 513);
  EXPECT_EQ(q.user_property("produced_utc"), "2026-11-26T10:00:00.000Z");
  EXPECT_EQ(q.payload, p.payload);
  const auto b = reader.next();
  ASSERT_TRUE(b);
  EXPECT_TRUE(decode_connack(*b).session_present);
  EXPECT_FALSE(reader.next());  // half a PINGRESP
  reader.feed(std::string_view("\x00", 1));
  EXPECT_EQ(reader.next()->type, MqttPacketType::pingresp);
}

TEST(MqttCodec, MalformedAndOversizedPacketsAreProtocolErrors) {
  const auto reader_error = [](const std::string& bytes, std::size_t max = 1 << 20) -> std::uint8_t {
    MqttPacketReader reader(max);
    reader.feed(bytes);
    try {
      while (auto p = reader.next())
        if (p->type == MqttPacketType::publish)
          (void)decode_publish(*p);
        else if (p->type == MqttPacketType::connack)
          (void)decode_connack(*p);
    } catch (const MqttProtocolError& e) {
      return e.reason_code();
    }
    return 0;
  };
  EXPECT_EQ(reader_error(std::string("\x30\xff\xff\xff\xff\x01", 6)), mqtt_malformed_packet);  // length > 4 bytes
  EXPECT_EQ(reader_error(std::string("\x30\x80\x80\x01", 4), 1000), mqtt_packet_too_large);
  EXPECT_EQ(reader_error(std::string("\x32\x05\x00\x09"
                                     "abc",
                                     7)),
            mqtt_malformed_packet);                                                                // topic past the end
  EXPECT_EQ(reader_error(std::string("\x30\x05\x00\x02\xc0\x80\x00", 7)), mqtt_malformed_packet);  // overlong UTF-8
  EXPECT_EQ(reader_error(std::string("\x30\x05\x00\x02"
                                     "a+\x00",
                                     7)),
            mqtt_malformed_packet);                                                                 // a wildcard
  EXPECT_EQ(reader_error(std::string("\x36\x06\x00\x01t\x00\x01\x00", 8)), mqtt_malformed_packet);  // QoS 3
  EXPECT_EQ(reader_error(std::string("\x20\x03\x00\x00\x05\xff\x00\x00\x00\x00\x00", 5)), mqtt_malformed_packet);
  EXPECT_EQ(reader_error(std::string("\x00\x00", 2)), mqtt_malformed_packet);  // reserved type 0
}

// Fuzz (property): any bytes from the broker end in packets, a wait for more, or a protocol error;
// never a crash, a hang or an unbounded buffer (run under ASan and UBSan in CI).
TEST(MqttCodec, RandomBytesNeverCrashTheReader) {
  std::mt19937 rng(20261127);
  MqttPublish seed;
  seed.topic = "g/m/params/dbb";
  seed.qos = 1;
  seed.packet_id = 7;
  seed.user_properties = {{"produced_utc", "2026-11-26T10:00:00.000Z"}};
  seed.payload = R"({"class":"PARAMS"})";
  const std::string valid = encode_publish(seed) + encode_connack(false, 0);
  for (int i = 0; i < 20000; ++i) {
    std::string bytes = valid;
    const int mutations = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < mutations; ++k) {
      switch (rng() % 3) {
        case 0:
          bytes[rng() % bytes.size()] = static_cast<char>(rng() & 0xFF);
          break;
        case 1:
          bytes.insert(rng() % bytes.size(), 1, static_cast<char>(rng() & 0xFF));
          break;
        default:
          bytes.erase(rng() % bytes.size(), 1);
          break;
      }
      if (bytes.empty()) bytes = "\x30";
    }
    MqttPacketReader reader(4096);
    reader.feed(bytes);
    try {
      while (auto p = reader.next()) {
        switch (p->type) {
          case MqttPacketType::publish:
            (void)decode_publish(*p);
            break;
          case MqttPacketType::connack:
            (void)decode_connack(*p);
            break;
          case MqttPacketType::suback:
            (void)decode_suback(*p);
            break;
          case MqttPacketType::disconnect:
            (void)decode_disconnect(*p);
            break;
          case MqttPacketType::puback:
            (void)decode_puback(*p);
            break;
          default:
            break;
        }
      }
    } catch (const MqttProtocolError&) {
    }
    EXPECT_LE(reader.buffered(), bytes.size());
  }
}

}  // namespace
}  // namespace guideway::plant
