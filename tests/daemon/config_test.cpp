// guidewayd's configuration (daemon/config.hpp): the embedded default, and every mistake in a file
// refused with its file, line and key (syntax, types, unknown keys, ranges, a world-writable socket, devices).
#include <gtest/gtest.h>

#include "core/toml_access.hpp"
#include "daemon/config.hpp"

using guideway::ConfigError;
using guideway::daemon::parse_config;

namespace {

// Returns the error text of parsing `text`, or "" if it parsed.
std::string error_of(const std::string& text) {
  try {
    parse_config(text, "test.toml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Config, EmbeddedDefaultParsesAndFillsPaths) {
  const auto c = guideway::daemon::default_config();
  EXPECT_EQ(c.source, "<embedded default>");
  EXPECT_FALSE(c.socket_path.empty());
  EXPECT_FALSE(c.state_dir.empty());
  EXPECT_EQ(c.socket_mode, 0660u);
}

TEST(Config, ReadsDaemonSettings) {
  const auto c = parse_config(R"(
[daemon]
socket = "/tmp/x.sock"
socket_mode = "0600"
tcp_listen = "127.0.0.1:2947"
ring_capacity = 1024
log_level = "debug"
)",
                              "t.toml");
  EXPECT_EQ(c.socket_path, "/tmp/x.sock");
  EXPECT_EQ(c.socket_mode, 0600u);
  EXPECT_EQ(c.tcp_host, "127.0.0.1");
  EXPECT_EQ(c.tcp_port, 2947);
  EXPECT_EQ(c.ring_capacity, 1024u);
  EXPECT_EQ(c.log_level, "debug");
}

TEST(Config, SyntaxErrorNamesFileAndLine) {
  const std::string e = error_of("[daemon]\nlog_level = \"info\"\nsocket = \n");
  EXPECT_NE(e.find("test.toml:3:"), std::string::npos) << e;
}

TEST(Config, WrongTypeNamesLineAndKey) {
  const std::string e = error_of("[daemon]\n\nstatus_period_s = \"fast\"\n");
  EXPECT_NE(e.find("test.toml:3: daemon.status_period_s: expected a number, got a string"), std::string::npos) << e;
}

TEST(Config, UnknownKeyIsRejectedWithItsLine) {
  const std::string e = error_of("[daemon]\nlog_level = \"info\"\nlog_levle = \"debug\"\n");
  EXPECT_NE(e.find("test.toml:3: daemon.log_levle: unknown key"), std::string::npos) << e;
}

TEST(Config, OutOfRangeAndBadChoiceAreExplained) {
  EXPECT_NE(error_of("[daemon]\nring_capacity = 1000\n").find("power of two"), std::string::npos);
  EXPECT_NE(error_of("[daemon]\nlog_level = \"loud\"\n").find("is not one of"), std::string::npos);
  EXPECT_NE(error_of("[daemon]\ntcp_listen = \"localhost\"\n").find("HOST:PORT"), std::string::npos);
  EXPECT_NE(error_of("[daemon]\nsocket_mode = \"rw\"\n").find("octal"), std::string::npos);
}

// A device's ring_capacity, else [daemon]'s, else none: the driver sizes the ring by its full rate
// (drivers/ring_capacity.hpp; tests/drivers/ring_capacity_test.cpp, tests/daemon/daemon_test.cpp).
TEST(Config, ADevicesRingIsItsOwnCapacityElseDaemonsElseTheRules) {
  const auto rule = parse_config("[[device]]\nname = \"a\"\ndriver = \"x\"\n", "t.toml");
  EXPECT_FALSE(rule.ring_capacity.has_value());
  EXPECT_FALSE(rule.devices.at(0).ring_capacity.has_value());
  const auto c = parse_config("[daemon]\nring_capacity = 4096\n[[device]]\nname = \"a\"\ndriver = \"x\"\n"
                              "[[device]]\nname = \"b\"\ndriver = \"x\"\nring_capacity = 131072\n",
                              "t.toml");
  EXPECT_EQ(c.devices.at(0).ring_capacity.value_or(0), 4096u);
  EXPECT_EQ(c.devices.at(1).ring_capacity.value_or(0), 131072u);
  const std::string e = error_of("[[device]]\nname = \"a\"\ndriver = \"x\"\nring_capacity = 3000\n");
  EXPECT_NE(e.find("test.toml:4: device[0].ring_capacity: must be a power of two"), std::string::npos) << e;
}

// A world-writable socket lets any local user start and stop sessions: refused with file:line, not
// accepted silently.
TEST(Config, WorldWritableSocketModeIsRefused) {
  for (const char* mode : {"0777", "0666", "0662"}) {
    const std::string e = error_of(std::string("[daemon]\nsocket_mode = \"") + mode + "\"\n");
    EXPECT_NE(e.find("test.toml:2"), std::string::npos) << e;
    EXPECT_NE(e.find("world-writable"), std::string::npos) << e;
  }
  EXPECT_TRUE(error_of("[daemon]\nsocket_mode = \"0664\"\n").empty());
}

TEST(Config, DevicesNeedUniqueNamesAndADriver) {
  EXPECT_NE(error_of("[[device]]\nname = \"a\"\n").find("device[0].driver: required key is missing"), std::string::npos);
  const std::string dup = error_of("[[device]]\nname = \"a\"\ndriver = \"x\"\n[[device]]\nname = \"a\"\ndriver = \"y\"\n");
  EXPECT_NE(dup.find("test.toml:5: device[1].name: duplicate device name"), std::string::npos) << dup;
}

TEST(Config, DisabledDevicesAreSkipped) {
  const auto c = parse_config("[[device]]\nname = \"a\"\ndriver = \"x\"\nenabled = false\n", "t.toml");
  EXPECT_TRUE(c.devices.empty());
}

// [explain] memory_mb: what each session's EXPLAIN may keep in its caches; absent, EXPLAIN's own default. A bad
// value is refused at its line (guidewayd --check-config prints this).
TEST(Config, ExplainMemoryBudget) {
  EXPECT_FALSE(parse_config("[daemon]\n", "t.toml").explain_memory_mb.has_value());
  EXPECT_EQ(parse_config("[explain]\nmemory_mb = 8\n", "t.toml").explain_memory_mb, 8u);
  EXPECT_EQ(parse_config("[explain]\nmemory_mb = 0\n", "t.toml").explain_memory_mb, 0u);
  EXPECT_NE(error_of("[explain]\n\nmemory_mb = -1\n").find("test.toml:3: explain.memory_mb"), std::string::npos)
      << error_of("[explain]\n\nmemory_mb = -1\n");
  EXPECT_NE(error_of("[explain]\nmemory_mb = \"16\"\n").find("test.toml:2: explain.memory_mb: expected"),
            std::string::npos)
      << error_of("[explain]\nmemory_mb = \"16\"\n");
  EXPECT_NE(error_of("[explain]\nmemory_mb = 16\nmemory = 4\n").find("test.toml:3: explain.memory: unknown key"),
            std::string::npos);
}
