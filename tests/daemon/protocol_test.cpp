// The daemon's JSON Lines protocol (daemon/protocol.hpp): requests parsed, or refused with a reason and
// their id; watch filters; each message class encoded once under its one wire name.
#include "daemon/protocol.hpp"

#include <gtest/gtest.h>

using namespace guideway::daemon;
using namespace guideway::results;

TEST(Protocol, VersionBannerCarriesClassAndProtocolVersion) {
  const auto v = version_message();
  EXPECT_EQ(v["class"], "VERSION");
  EXPECT_EQ(v["proto_major"], protocol_major);
  EXPECT_TRUE(v.contains("release"));
}

TEST(Protocol, ParsesRequestsCaseInsensitivelyAndKeepsId) {
  RequestError err;
  auto r = parse_request(R"({"class":"STATUS","id":7})", err);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->cls, "status");
  ASSERT_TRUE(r->id);
  EXPECT_EQ(*r->id, 7);
}

TEST(Protocol, RejectsMalformedRequestsWithAReason) {
  RequestError err;
  EXPECT_FALSE(parse_request("{not json", err));
  EXPECT_EQ(err.message, "malformed JSON");
  EXPECT_FALSE(parse_request("[1,2]", err));
  EXPECT_NE(err.message.find("object"), std::string::npos);
  EXPECT_FALSE(parse_request(R"({"cls":"status"})", err));
  EXPECT_NE(err.message.find("class"), std::string::npos);
  EXPECT_FALSE(parse_request(R"({"class":3})", err));
}

TEST(Protocol, ARefusedRequestKeepsItsIdForTheError) {
  RequestError err;
  EXPECT_FALSE(parse_request(R"({"id":5})", err));
  ASSERT_TRUE(err.id);
  EXPECT_EQ(*err.id, 5);
  EXPECT_FALSE(parse_request(R"({"class":3,"id":"a"})", err));
  ASSERT_TRUE(err.id);
  EXPECT_EQ(*err.id, "a");
  EXPECT_FALSE(parse_request("{not json", err));
  EXPECT_FALSE(err.id) << "the id of an earlier request must not leak into this one";
}

TEST(Protocol, ANulByteOrAnEmptyLineIsRefusedNotCut) {
  RequestError err;
  using namespace std::string_view_literals;
  EXPECT_FALSE(parse_request("{\"class\":\"version\"}\0junk"sv, err));
  EXPECT_EQ(err.message, "a request must not contain a NUL byte");
  EXPECT_FALSE(parse_request("\0"sv, err));
  for (const std::string_view blank : {""sv, " "sv, "\t \r"sv}) {
    EXPECT_FALSE(parse_request(blank, err));
    EXPECT_NE(err.message.find("empty request"), std::string::npos) << err.message;
  }
}

TEST(Protocol, WatchSelectsClassesAndChannels) {
  Subscription sub;
  EXPECT_FALSE(sub.wants(MessageClass::status, ""));
  auto reply = apply_watch(nlohmann::json{{"class", "watch"}}, sub);
  EXPECT_EQ(reply["class"], "WATCH");
  EXPECT_TRUE(sub.wants(MessageClass::status, ""));
  EXPECT_TRUE(sub.wants(MessageClass::event, "dbb"));
  EXPECT_FALSE(sub.wants(MessageClass::sample, "dbb"));  // live data only when asked for
  apply_watch(nlohmann::json{{"classes", {"sample"}}, {"channels", {"dbb"}}}, sub);
  EXPECT_TRUE(sub.wants(MessageClass::sample, "dbb"));
  EXPECT_FALSE(sub.wants(MessageClass::sample, "autocollimator"));
  EXPECT_FALSE(sub.wants(MessageClass::status, ""));
  apply_watch(nlohmann::json{{"classes", {"PARAMS"}}, {"channels", {"dbb-dbb-20261121T063102Z"}}}, sub);
  EXPECT_TRUE(sub.wants(MessageClass::params, "dbb", "dbb-dbb-20261121T063102Z"));  // a session by name
  EXPECT_FALSE(sub.wants(MessageClass::params, "dbb", "dbb-dbb-20261121T070000Z"));
  EXPECT_FALSE(sub.wants(MessageClass::params, "dbb"));
  apply_watch(nlohmann::json{{"enable", false}}, sub);
  EXPECT_FALSE(sub.wants(MessageClass::status, ""));
}

TEST(Protocol, WatchRejectsUnknownClassesAndBadTypes) {
  Subscription sub;
  EXPECT_THROW(apply_watch(nlohmann::json{{"classes", {"NOPE"}}}, sub), std::invalid_argument);
  EXPECT_THROW(apply_watch(nlohmann::json{{"classes", "STATUS"}}, sub), std::invalid_argument);
  EXPECT_THROW(apply_watch(nlohmann::json{{"enable", "yes"}}, sub), std::invalid_argument);
}

TEST(Messages, EveryClassHasOneWireNameAndOnlyPublishedOnesCanBeWatched) {
  for (const auto cls : {MessageClass::status, MessageClass::sample, MessageClass::params, MessageClass::explain,
                         MessageClass::event}) {
    EXPECT_TRUE(is_published(cls));
    EXPECT_EQ(published_class(to_string(cls)), cls);
  }
  for (const auto cls : {MessageClass::version, MessageClass::error, MessageClass::watch, MessageClass::session,
                         MessageClass::report, MessageClass::recordings}) {
    EXPECT_FALSE(is_published(cls)) << to_string(cls);
    EXPECT_FALSE(published_class(to_string(cls))) << "a reply is not something to watch";
  }
  EXPECT_EQ(published_class_names(), "STATUS, SAMPLE, PARAMS, EXPLAIN, EVENT");
  EXPECT_FALSE(published_class("params")) << "wire names are upper case; apply_watch upper-cases requests";
}

TEST(Messages, APublishedMessageIsEncodedOnceWithItsClass) {
  const Message params = make_message(MessageClass::params, {{"kind", "dbb"}, {"squareness_urad", 1.5}}, "dbb", "s1");
  EXPECT_EQ(params.line, R"({"class":"PARAMS","kind":"dbb","squareness_urad":1.5})");
  EXPECT_EQ(params.body["class"], "PARAMS") << "the daemon keeps PARAMS from the object, not by parsing the line";
  EXPECT_EQ(params.channel, "dbb");
  EXPECT_EQ(params.session, "s1");
  const Message sample = make_message(MessageClass::sample, {{"device", "dbb"}, {"seq", 3}}, "dbb");
  EXPECT_EQ(sample.line, R"({"class":"SAMPLE","device":"dbb","seq":3})");
  EXPECT_TRUE(sample.body.is_null()) << "a SAMPLE's object is not kept beside its line";
}

TEST(Messages, AnEventLeavesOutWhatItDoesNotKnow) {
  const Message device = make_message(Event{.event = "lost", .time = "2026-11-26T08:00:00Z", .device = "dbb",
                                            .reason = "no frames for 1 s"});
  EXPECT_EQ(device.line,
            R"({"class":"EVENT","device":"dbb","event":"lost","reason":"no frames for 1 s","time":"2026-11-26T08:00:00Z"})");
  EXPECT_EQ(device.channel, "dbb");
  EXPECT_EQ(device.session, "");
  const Message report = make_message(Event{.event = "report_ready", .device = "dbb", .session = "s1", .file = "/r.html"});
  EXPECT_EQ(report.line, R"({"class":"EVENT","device":"dbb","event":"report_ready","file":"/r.html","session":"s1"})");
  EXPECT_EQ(report.session, "s1") << "the session's watchers by name get its events";
  EXPECT_FALSE(report.body.contains("reason")) << "the daemon logs an event with a reason as a warning";
}
