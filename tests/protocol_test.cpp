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
  std::string err;
  auto r = parse_request(R"({"class":"STATUS","id":7})", err);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->cls, "status");
  ASSERT_TRUE(r->id);
  EXPECT_EQ(*r->id, 7);
}

TEST(Protocol, RejectsMalformedRequestsWithAReason) {
  std::string err;
  EXPECT_FALSE(parse_request("{not json", err));
  EXPECT_EQ(err, "malformed JSON");
  EXPECT_FALSE(parse_request("[1,2]", err));
  EXPECT_NE(err.find("object"), std::string::npos);
  EXPECT_FALSE(parse_request(R"({"cls":"status"})", err));
  EXPECT_NE(err.find("class"), std::string::npos);
  EXPECT_FALSE(parse_request(R"({"class":3})", err));
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
