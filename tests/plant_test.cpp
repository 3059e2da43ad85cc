// plant/: the MQTT topic tree, broker addresses and the publisher's on-disk journal (its bounds, its
// survival across a restart, files a crash cut short). The publisher against a real broker is
// tests/mqtt_daemon_test.py.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "plant/broker_address.hpp"
#include "plant/message_journal.hpp"
#include "plant/topics.hpp"
#include "test_support.hpp"

namespace guideway::plant {
namespace {

using test::TempDir;

TEST(Topics, EveryLeafRoundTrips) {
  EXPECT_EQ(topic_for("guideway", "mill-1", TopicLeaf::params, "dbb"), "guideway/mill-1/params/dbb");
  EXPECT_EQ(topic_for("plant/a", "mill-1", TopicLeaf::status), "plant/a/mill-1/status");
  for (TopicLeaf leaf : {TopicLeaf::status, TopicLeaf::params, TopicLeaf::explain, TopicLeaf::event, TopicLeaf::devices}) {
    const auto t = parse_topic("plant/a", topic_for("plant/a", "m", leaf, "runout"));
    ASSERT_TRUE(t) << to_string(leaf);
    EXPECT_EQ(t->machine, "m");
    EXPECT_EQ(t->leaf, leaf);
    EXPECT_EQ(t->kind, leaf == TopicLeaf::params || leaf == TopicLeaf::explain ? "runout" : "");
  }
}

TEST(Topics, TopicsOutsideTheTreeAreNotTakenApart) {
  for (const char* topic : {"guideway", "guideway/", "guideway/m", "guideway/m/params", "guideway/m/params/",
                            "guideway/m/status/x", "guideway/m/other", "guidewayx/m/status", "other/m/status",
                            "guideway//status", "guideway/m/params/a/b"}) {
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
                          "mqtt://b:65536", "mqtt://b:18x", "mqtt://user:pw@b", "mqtt://b/topic", "mqtts://[::1"}) {
    EXPECT_THROW(parse_broker_url(bad), std::invalid_argument) << bad;
  }
  try {
    parse_broker_url("http://b");
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("mqtt://HOST[:PORT]"), std::string::npos) << e.what();
  }
}

JournalEntry entry(int i, std::size_t payload_bytes = 10) {
  return {"guideway/m/event", std::to_string(i) + std::string(payload_bytes, 'x'), "2026-11-26T10:00:00.000Z", i % 2 == 0};
}

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
    MessageJournal j(path, 100, 1 << 20);
    for (int i = 0; i < 5; ++i) EXPECT_EQ(j.push(entry(i)), 0u);
    j.pop_front();
    EXPECT_EQ(j.size(), 4u);
  }
  EXPECT_EQ(std::filesystem::status(path).permissions() & std::filesystem::perms::all, std::filesystem::perms::owner_all);
  MessageJournal j(path, 100, 1 << 20);
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
  MessageJournal by_count(dir.file("a"), 3, 1 << 20);
  std::size_t dropped = 0;
  for (int i = 0; i < 5; ++i) dropped += by_count.push(entry(i));
  EXPECT_EQ(dropped, 2u);
  EXPECT_EQ(drain(by_count), (std::vector<std::string>{"2", "3", "4"}));

  MessageJournal by_bytes(dir.file("b"), 1000, 1000);
  dropped = 0;
  for (int i = 0; i < 10; ++i) dropped += by_bytes.push(entry(i, 300));
  EXPECT_LE(by_bytes.bytes(), 1000u);
  EXPECT_EQ(dropped + by_bytes.size(), 10u);
  EXPECT_EQ(drain(by_bytes).back(), "9");
  // One message over the byte bound alone is kept: the bound is on the backlog.
  EXPECT_EQ(by_bytes.push(entry(10, 5000)), 0u);
  EXPECT_EQ(by_bytes.size(), 1u);
}

TEST(MessageJournal, AFileACrashCutShortIsSkippedAndCounted) {
  TempDir dir;
  const std::string path = dir.file("journal");
  {
    MessageJournal j(path, 100, 1 << 20);
    for (int i = 0; i < 3; ++i) j.push(entry(i));
  }
  std::vector<std::filesystem::path> files;
  for (const auto& f : std::filesystem::directory_iterator(path)) files.push_back(f.path());
  std::sort(files.begin(), files.end());
  std::filesystem::resize_file(files[1], 20);                   // truncated
  std::ofstream(path + "/00000000000000000009.msg.part") << "x";  // a write cut short
  MessageJournal j(path, 100, 1 << 20);
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

}  // namespace
}  // namespace guideway::plant
