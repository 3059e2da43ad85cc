#include "daemon/protocol.hpp"

#include <gtest/gtest.h>

using namespace guideway::daemon;

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
  EXPECT_FALSE(sub.wants("STATUS", ""));
  auto reply = apply_watch(nlohmann::json{{"class", "watch"}}, sub);
  EXPECT_EQ(reply["class"], "WATCH");
  EXPECT_TRUE(sub.wants("STATUS", ""));
  EXPECT_TRUE(sub.wants("EVENT", "dbb"));
  EXPECT_FALSE(sub.wants("SAMPLE", "dbb"));  // live data only when asked for
  apply_watch(nlohmann::json{{"classes", {"sample"}}, {"channels", {"dbb"}}}, sub);
  EXPECT_TRUE(sub.wants("SAMPLE", "dbb"));
  EXPECT_FALSE(sub.wants("SAMPLE", "autocollimator"));
  EXPECT_FALSE(sub.wants("STATUS", ""));
  apply_watch(nlohmann::json{{"classes", {"PARAMS"}}, {"channels", {"dbb-dbb-20261121T063102Z"}}}, sub);
  EXPECT_TRUE(sub.wants("PARAMS", "dbb", "dbb-dbb-20261121T063102Z"));  // a session by name
  EXPECT_FALSE(sub.wants("PARAMS", "dbb", "dbb-dbb-20261121T070000Z"));
  EXPECT_FALSE(sub.wants("PARAMS", "dbb"));
  apply_watch(nlohmann::json{{"enable", false}}, sub);
  EXPECT_FALSE(sub.wants("STATUS", ""));
}

TEST(Protocol, WatchRejectsUnknownClassesAndBadTypes) {
  Subscription sub;
  EXPECT_THROW(apply_watch(nlohmann::json{{"classes", {"NOPE"}}}, sub), std::invalid_argument);
  EXPECT_THROW(apply_watch(nlohmann::json{{"classes", "STATUS"}}, sub), std::invalid_argument);
  EXPECT_THROW(apply_watch(nlohmann::json{{"enable", "yes"}}, sub), std::invalid_argument);
}
