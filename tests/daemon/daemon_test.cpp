// The daemon in-process: real sockets, real pipeline thread, a real driver thread (a counting
// source), talking JSON Lines through the same client the CLI uses.
#include "daemon/daemon.hpp"

#include <spdlog/sinks/ostream_sink.h>
#include <unistd.h>
#include <sstream>
#include <sys/wait.h>
#include <sys/stat.h>
#include <csignal>
#include <gtest/gtest.h>
#include <spdlog/sinks/null_sink.h>
#include <sys/socket.h>
#include <sys/un.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <thread>

#include "cli/daemon_client.hpp"
#include "core/mono_clock.hpp"
#include "counting_driver.hpp"
#include "drivers/builtin.hpp"
#include "test_support.hpp"

using namespace guideway;
using guideway::cli::DaemonClient;

namespace {

struct RunningDaemon {
  // `builtin_drivers`: the instruments' drivers too (as guidewayd has them), beside "counting".
  explicit RunningDaemon(const std::string& extra_toml = "", spdlog::sink_ptr sink = nullptr,
                         bool builtin_drivers = false) {
    registry.add("counting", "test source", [](const drivers::DeviceConfig& c) {
      return std::make_unique<test::CountingDriver>(c);
    });
    if (builtin_drivers) drivers::register_builtin_drivers(registry);
    socket = dir.file("d.sock");
    auto config = daemon::parse_config("[daemon]\nsocket = \"" + socket +
                                           "\"\nstatus_period_s = 0.1\nclient_queue_bytes = 65536\n" + extra_toml,
                                       "test.toml");
    auto log = std::make_shared<spdlog::logger>("test", sink ? sink : std::make_shared<spdlog::sinks::null_sink_mt>());
    log->set_level(spdlog::level::info);
    d = std::make_unique<daemon::Daemon>(std::move(config), registry, sessions, log);
    thread = std::thread([this] { d->run(); });
  }
  ~RunningDaemon() {
    d->request_stop();
    thread.join();
  }
  test::TempDir dir;
  drivers::DriverRegistry registry;
  sessions::SessionRegistry sessions;
  std::string socket;
  std::unique_ptr<daemon::Daemon> d;
  std::thread thread;
};

}  // namespace

TEST(Daemon, GreetsWithVersionAndAnswersStatus) {
  RunningDaemon rd;
  DaemonClient c(rd.socket);
  EXPECT_EQ(c.banner()["class"], "VERSION");
  EXPECT_EQ(c.banner()["proto_major"], 1);
  auto s = c.request({{"class", "status"}, {"id", "abc"}}, guideway::results::MessageClass::status);
  EXPECT_EQ(s["class"], "STATUS");
  EXPECT_EQ(s["id"], "abc");
  EXPECT_TRUE(s["devices"].empty());
  EXPECT_EQ(s["socket"], rd.socket);
}

TEST(Daemon, SurvivesMalformedUnknownAndOversizedRequests) {
  RunningDaemon rd;
  DaemonClient c(rd.socket);
  c.send_line("{this is not json");
  auto e1 = c.request({{"class", "version"}}, guideway::results::MessageClass::error);
  EXPECT_EQ(e1["message"], "malformed JSON");
  auto e2 = c.request({{"class", "frobnicate"}}, guideway::results::MessageClass::error);
  EXPECT_NE(e2["message"].get<std::string>().find("unknown request class"), std::string::npos);
  c.send_line(std::string(100000, 'x'));  // 100 kB in one line, limit is 16 kB
  auto e3 = c.request({{"class", "version"}}, guideway::results::MessageClass::error);
  EXPECT_NE(e3["message"].get<std::string>().find("exceeds the limit"), std::string::npos);
  // The connection is still usable and answers normally.
  auto v = c.request({{"class", "version"}}, guideway::results::MessageClass::version);
  EXPECT_EQ(v["class"], "VERSION");
}

// Issue 46 item 11: a request longer than the limit and no newline after it (a client that never sends
// one) is answered as soon as the limit is passed, once; the line's rest is discarded up to its newline.
TEST(Daemon, ALongRequestWithoutANewlineIsAnsweredAtOnce) {
  RunningDaemon rd;
  const int fd = socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::strncpy(a.sun_path, rd.socket.c_str(), sizeof(a.sun_path) - 1);
  ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
  const std::string big(20000, 'x');
  ASSERT_EQ(write(fd, big.data(), big.size()), static_cast<ssize_t>(big.size()));
  std::string got;
  const auto read_lines = [&](std::size_t lines) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
    while (static_cast<std::size_t>(std::count(got.begin(), got.end(), '\n')) < lines &&
           std::chrono::steady_clock::now() < deadline) {
      char buf[4096];
      const ssize_t n = recv(fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n > 0) got.append(buf, static_cast<std::size_t>(n));
      else std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  };
  read_lines(2);  // the banner, then the ERROR, with no newline sent
  ASSERT_EQ(std::count(got.begin(), got.end(), '\n'), 2) << got;
  const auto error = nlohmann::json::parse(got.substr(got.find('\n') + 1));
  EXPECT_EQ(error["class"], "ERROR");
  EXPECT_EQ(error["message"].get<std::string>().rfind("request of more than 16384 bytes (no end of line after ", 0), 0u)
      << error;
  const std::string rest = std::string(5000, 'y') + "\n{\"class\":\"version\"}\n";  // the line ends, then one more
  ASSERT_EQ(write(fd, rest.data(), rest.size()), static_cast<ssize_t>(rest.size()));
  read_lines(3);
  ASSERT_EQ(std::count(got.begin(), got.end(), '\n'), 3) << got;
  const std::string last = got.substr(got.rfind('\n', got.size() - 2) + 1);
  EXPECT_EQ(nlohmann::json::parse(last)["class"], "VERSION") << "one reply for the long line, no second ERROR";
  close(fd);
}

// Issue 46 item 11: a numeric id is echoed as sent; one a double cannot hold (it came back as
// 1.2345678901234568e+29) is refused, saying so.
TEST(Daemon, ANumberIdIsEchoedExactlyOrRefused) {
  RunningDaemon rd;
  DaemonClient c(rd.socket);
  c.send_line(R"({"class":"version","id":123456789012345678901234567890})");
  auto e = nlohmann::json::parse(*c.read_line(std::chrono::seconds(5)));
  EXPECT_EQ(e["class"], "ERROR");
  EXPECT_FALSE(e.contains("id"));
  EXPECT_EQ(e["message"], "\"id\" 123456789012345678901234567890 cannot be echoed exactly: a number id has at most 15 "
                          "significant digits or is a 64-bit integer (send a longer one as a string)");
  c.send_line(R"({"class":"version","id":18446744073709551615})");
  EXPECT_NE(c.read_line(std::chrono::seconds(5))->find(R"("id":18446744073709551615)"), std::string::npos);
  c.send_line(R"({"class":"version","id":0.1})");
  EXPECT_NE(c.read_line(std::chrono::seconds(5))->find(R"("id":0.1)"), std::string::npos);
  c.send_line(R"({"class":"version","id":1e21})");
  EXPECT_EQ(nlohmann::json::parse(*c.read_line(std::chrono::seconds(5)))["id"], 1e21);
}

TEST(Daemon, EveryLineGetsOneReplyAndARefusedOneKeepsItsId) {
  RunningDaemon rd;
  DaemonClient c(rd.socket);
  // Each line below gets exactly one reply, in order: the status request after them is answered next.
  c.send_line(R"({"id":5})");
  c.send_line(std::string(R"({"class":"version","id":6})") + std::string(1, '\0') + "junk");
  c.send_line("");
  c.send_line("   ");
  c.send({{"class", "status"}, {"id", 9}});
  std::vector<nlohmann::json> replies;
  while (replies.size() < 5) {
    const auto line = c.read_line(std::chrono::seconds(5));
    ASSERT_TRUE(line) << "a line got no reply; replies so far: " << replies.size();
    replies.push_back(nlohmann::json::parse(*line));
  }
  EXPECT_EQ(replies[0]["class"], "ERROR");
  EXPECT_EQ(replies[0]["id"], 5) << replies[0];
  EXPECT_EQ(replies[1]["class"], "ERROR") << "bytes after a NUL are not ignored";
  EXPECT_EQ(replies[1]["message"], "a request must not contain a NUL byte");
  for (int i : {2, 3}) {
    EXPECT_EQ(replies[i]["class"], "ERROR") << replies[i];
    EXPECT_NE(replies[i]["message"].get<std::string>().find("empty request"), std::string::npos) << replies[i];
  }
  EXPECT_EQ(replies[4]["class"], "STATUS");
  EXPECT_EQ(replies[4]["id"], 9);
}

TEST(Daemon, StreamsSamplesFromADriverThroughThePipeline) {
  RunningDaemon rd(
      "sample_publish_hz = 50.0\n[[device]]\nname = \"counter\"\ndriver = \"counting\"\nrate_hz = 2000.0\n");
  DaemonClient c(rd.socket);
  auto ack = c.request({{"class", "watch"}, {"classes", {"SAMPLE", "STATUS"}}}, guideway::results::MessageClass::watch);
  ASSERT_EQ(ack["class"], "WATCH");
  int samples = 0;
  double last = -1;
  bool saw_status_with_flow = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while ((samples < 10 || !saw_status_with_flow) && std::chrono::steady_clock::now() < deadline) {
    auto line = c.read_line(std::chrono::milliseconds(500));
    if (!line) continue;
    auto j = nlohmann::json::parse(*line);
    if (j["class"] == "SAMPLE") {
      EXPECT_EQ(j["device"], "counter");
      const double v = j["values"]["count"];
      EXPECT_GT(v, last);  // decimated, but in order
      last = v;
      ++samples;
    } else if (j["class"] == "STATUS") {
      const auto& dev = j["devices"][0];
      EXPECT_EQ(dev["counters"]["overruns"], 0);
      EXPECT_EQ(dev["seq_gaps"], 0);
      EXPECT_EQ(dev["driver_counters"], nlohmann::json::object()) << "a driver with no counters of its own";
      // Before its thread first runs the device is "connecting"; once samples flowed it streams.
      if (dev["consumed"].get<std::uint64_t>() > 100) {
        EXPECT_EQ(dev["state"], "streaming");
        saw_status_with_flow = true;
      }
    }
  }
  EXPECT_GE(samples, 10);
  EXPECT_TRUE(saw_status_with_flow);
}

// A client that connects and resets the connection before reading the greeting was one warning each
// time (5000 lines from a loop of 5000): the same reason is logged once, then counted.
TEST(Daemon, ClientsDroppedForOneReasonAreLoggedOnceThenCounted) {
  std::ostringstream out;
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(out);
  {
    RunningDaemon rd("", sink);
    for (int i = 0; i < 300; ++i) {
      const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
      ASSERT_GE(fd, 0);
      sockaddr_un addr{};
      addr.sun_family = AF_UNIX;
      std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", rd.socket.c_str());
      if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0) {
        linger l{1, 0};  // close with a reset, before reading anything
        ::setsockopt(fd, SOL_SOCKET, SO_LINGER, &l, sizeof l);
      }
      ::close(fd);
    }
    DaemonClient c(rd.socket);  // still answers
    EXPECT_EQ(c.request({{"class", "version"}}, guideway::results::MessageClass::version)["class"], "VERSION");
  }
  std::istringstream in(out.str());
  int dropped_lines = 0;
  for (std::string line; std::getline(in, line);) dropped_lines += line.find("dropped") != std::string::npos;
  EXPECT_LE(dropped_lines, 3) << out.str().substr(0, 2000);
}

namespace {
int raw_connect(const std::string& path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}
// The first line the server sends on fd (the greeting, or "too many clients"), "" when it closes first.
std::string first_line(int fd) {
  std::string s;
  char c = 0;
  timeval tv{2, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  while (::read(fd, &c, 1) == 1 && c != '\n') s += c;
  return s;
}
}  // namespace

// 256 idle connections locked everyone out for good: a connection that has not completed a request
// within idle_timeout_s is closed, and one that asked something stays.
TEST(Daemon, IdleConnectionsAreClosedAndDoNotLockOthersOut) {
  RunningDaemon rd("max_clients = 3\nreserved_clients = 0\nidle_timeout_s = 0.5\n");
  DaemonClient watcher(rd.socket);
  watcher.request({{"class", "watch"}, {"classes", {"STATUS"}}},
                  guideway::results::MessageClass::watch);  // served: stays
  std::vector<int> idle;
  for (int i = 0; i < 2; ++i) idle.push_back(raw_connect(rd.socket));
  const int refused = raw_connect(rd.socket);
  EXPECT_NE(first_line(refused).find("too many clients"), std::string::npos);
  ::close(refused);
  // After the timeout the idle ones are gone and a newcomer is served.
  std::this_thread::sleep_for(std::chrono::milliseconds(900));
  for (int fd : idle) {
    first_line(fd);  // the greeting, then end of file
    char c = 0;
    EXPECT_EQ(::read(fd, &c, 1), 0) << "an idle connection was kept";
    ::close(fd);
  }
  DaemonClient late(rd.socket);
  EXPECT_EQ(late.request({{"class", "version"}}, guideway::results::MessageClass::version)["class"], "VERSION");
  EXPECT_EQ(watcher.request({{"class", "version"}}, guideway::results::MessageClass::version)["class"],
            "VERSION");  // the watcher stayed
}

// The last reserved_clients places are for root and the daemon's own user or group: connections from
// another uid fill the rest and are refused, root still gets in.
TEST(Daemon, ReservedPlacesKeepTheOperatorIn) {
  if (::geteuid() != 0) GTEST_SKIP() << "connecting as another uid needs root";
  RunningDaemon rd("max_clients = 4\nreserved_clients = 2\nidle_timeout_s = 0\n");
  ::chmod(rd.dir.path().c_str(), 0755);
  ::chmod(rd.socket.c_str(), 0666);  // let uid 12345 reach it (the test's doing, not the daemon's)
  int pipe_fds[2];
  ASSERT_EQ(::pipe(pipe_fds), 0);
  sockaddr_un addr{};  // prepared here: the forked child of this multithreaded test must not allocate
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", rd.socket.c_str());
  const pid_t child = ::fork();
  if (child == 0) {  // another user: fills what is open to all, the third is refused
    if (::setgid(12345) != 0 || ::setuid(12345) != 0) ::_exit(2);
    const auto line_has = [&](const char* what) {  // connects; the first line holds `what`
      const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
      if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) return false;
      char buf[512] = {};
      std::size_t n = 0;
      while (n + 1 < sizeof buf && ::read(fd, buf + n, 1) == 1 && buf[n] != '\n') ++n;
      return std::strstr(buf, what) != nullptr;
    };
    const bool ok = line_has("VERSION") && line_has("VERSION") && line_has("too many clients");
    char done = ok ? 'y' : 'n';
    [[maybe_unused]] auto w = ::write(pipe_fds[1], &done, 1);
    ::pause();  // keeps its two connections until killed
    ::_exit(0);
  }
  char verdict = 0;
  ASSERT_EQ(::read(pipe_fds[0], &verdict, 1), 1);
  EXPECT_EQ(verdict, 'y');
  DaemonClient root(rd.socket);  // a reserved place
  EXPECT_EQ(root.request({{"class", "version"}}, guideway::results::MessageClass::version)["class"], "VERSION");
  ::kill(child, SIGKILL);
  ::waitpid(child, nullptr, 0);
}

// protocol.md: STATUS `pipeline` gives figures over the last status period (0.1 s here). At 2000
// samples/s a period takes about 200; counted since the start they grew without bound (the CLI printed
// "241993 samples in the last period" 47 s after start).
// Each device's ring holds 8 s of its own full rate, a power of two, at least 1,024 (drivers/ring_capacity.hpp),
// unless its table gives a larger one: what STATUS shows, the sizes written out.
TEST(Daemon, StatusShowsEachDevicesRingSizedToItsFullRate) {
  RunningDaemon rd(
      "[[device]]\nname = \"dbb\"\ndriver = \"dbb-can\"\nbus = \"unix:/nonexistent/can.sock\"\nsync_rate_hz = 1000.0\n"
      "[[device.encoder]]\nchannel = \"bar_length\"\nnode_id = 1\nresolution_nm = 100\noffset_mm = 100\n"
      "[[device.encoder]]\nchannel = \"x\"\nnode_id = 2\nresolution_nm = 100\n"
      "[[device.encoder]]\nchannel = \"y\"\nnode_id = 3\nresolution_nm = 100\n"
      "[[device]]\nname = \"gauge\"\ndriver = \"micrometer-modbus\"\nhost = \"127.0.0.1\"\nport = 1\n"
      "[[device]]\nname = \"counter\"\ndriver = \"counting\"\nrate_hz = 3000.0\n"
      "[[device]]\nname = \"slow\"\ndriver = \"counting\"\nrate_hz = 10.0\nring_capacity = 4096\n",
      nullptr, true);
  DaemonClient c(rd.socket);
  const auto s = c.request({{"class", "status"}}, guideway::results::MessageClass::status);
  std::map<std::string, std::size_t> capacity;
  for (const auto& d : s["devices"]) capacity[d["name"].get<std::string>()] = d["ring"]["capacity"].get<std::size_t>();
  EXPECT_EQ(capacity, (std::map<std::string, std::size_t>{
                          {"dbb", 8192},       // SYNC at 1 kHz: 8,000
                          {"gauge", 1024},     // polled at 50 Hz: 400, the least
                          {"counter", 32768},  // 3 kHz: 24,000
                          {"slow", 4096}}));   // its own, larger than the rule's 1,024
}

TEST(Daemon, StatusPipelineCountsTheLastPeriodOnly) {
  RunningDaemon rd("[[device]]\nname = \"counter\"\ndriver = \"counting\"\nrate_hz = 2000.0\n");
  DaemonClient c(rd.socket);
  c.request({{"class", "watch"}, {"classes", {"STATUS"}}}, guideway::results::MessageClass::watch);
  std::vector<std::uint64_t> per_period, iterations;
  std::uint64_t consumed = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (per_period.size() < 20 && std::chrono::steady_clock::now() < deadline) {
    auto line = c.read_line(std::chrono::milliseconds(500));
    if (!line) continue;
    auto j = nlohmann::json::parse(*line);
    if (j["class"] != "STATUS") continue;
    consumed = j["devices"][0]["consumed"].get<std::uint64_t>();
    if (consumed < 400) continue;  // streaming for two periods at least
    per_period.push_back(j["pipeline"]["samples"].get<std::uint64_t>());
    iterations.push_back(j["pipeline"]["iterations"].get<std::uint64_t>());
  }
  ASSERT_EQ(per_period.size(), 20u);
  std::uint64_t sum = 0;
  for (auto v : per_period) sum += v;
  // The periods' counts add up to no more than the device delivered, and each is one period's
  // (0.1 s x 2000/s = 200, generous for a loaded machine), not the total so far.
  EXPECT_LE(sum, consumed);
  for (std::size_t k = 0; k < per_period.size(); ++k) {
    EXPECT_LE(per_period[k], 2000u) << k;
    EXPECT_LE(iterations[k], 100000u) << k;
  }
  EXPECT_LT(per_period.back(), consumed / 2);
}

// protocol.md: "Fields whose value is unknown are left out, never null". A NaN reading (a lost beam)
// is not a number JSON can carry: nlohmann would write null.
TEST(Daemon, ASampleWithoutAValueLeavesTheChannelOutNeverNull) {
  RunningDaemon rd(
      "sample_publish_hz = 200.0\n[[device]]\nname = \"counter\"\ndriver = \"counting\"\nrate_hz = 2000.0\n"
      "nan_every = 2\n");
  DaemonClient c(rd.socket);
  c.request({{"class", "watch"}, {"classes", {"SAMPLE"}}}, guideway::results::MessageClass::watch);
  int with_value = 0, without_value = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while ((with_value < 5 || without_value < 5) && std::chrono::steady_clock::now() < deadline) {
    auto line = c.read_line(std::chrono::milliseconds(500));
    if (!line) continue;
    auto j = nlohmann::json::parse(*line);
    if (j["class"] != "SAMPLE") continue;
    ASSERT_EQ(line->find("null"), std::string::npos) << *line;
    if (j["values"].contains("count")) {
      EXPECT_TRUE(j["values"]["count"].is_number()) << *line;
      EXPECT_FALSE(j.contains("flags")) << *line;
      ++with_value;
    } else {
      EXPECT_EQ(j["flags"], 2) << *line;  // no signal: the flag says why the value is missing
      ++without_value;
    }
  }
  EXPECT_GE(with_value, 5);
  EXPECT_GE(without_value, 5);
}

TEST(Daemon, DenoisesAConfiguredChannelAndPublishesItBesideTheRawValue) {
  // The counting driver's value is its sample count: a straight line, which a db4 wavelet (four vanishing
  // moments) leaves unchanged away from the stream's start, so the denoised value must equal its own seq.
  RunningDaemon rd(
      "sample_publish_hz = 50.0\n[[device]]\nname = \"counter\"\ndriver = \"counting\"\nrate_hz = 2000.0\n"
      "[[processing]]\ndevice = \"counter\"\nchannel = \"count\"\nwavelet = \"db4\"\nlevels = 4\n");
  DaemonClient c(rd.socket);
  c.request({{"class", "watch"}, {"classes", {"SAMPLE"}}}, guideway::results::MessageClass::watch);
  int checked = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (checked < 5 && std::chrono::steady_clock::now() < deadline) {
    auto line = c.read_line(std::chrono::milliseconds(500));
    if (!line) continue;
    auto j = nlohmann::json::parse(*line);
    if (j["class"] != "SAMPLE" || !j.contains("denoised")) continue;
    const auto seq = j["denoised"]["seq"].get<std::uint64_t>();
    if (seq < 1000) continue;  // past the start-up edge
    EXPECT_LE(seq + 105, j["seq"].get<std::uint64_t>());  // at least the latency (F-1)(2^J-1) behind
    EXPECT_NEAR(j["denoised"]["values"]["count"].get<double>(), static_cast<double>(seq), 1e-6);
    ++checked;
  }
  EXPECT_EQ(checked, 5);
  auto s = c.request({{"class", "status"}}, guideway::results::MessageClass::status);
  const auto& p = s["devices"][0]["processing"][0];
  EXPECT_EQ(p["channel"], "count");
  EXPECT_EQ(p["wavelet"], "db4");
  EXPECT_EQ(p["latency_samples"], 105);
}

TEST(Daemon, ProcessingOfAnUnknownChannelIsAConfigErrorNamingTheDevicesChannels) {
  test::TempDir dir;
  drivers::DriverRegistry registry;
  registry.add("counting", "test source", [](const drivers::DeviceConfig& c) {
    return std::make_unique<test::CountingDriver>(c);
  });
  auto config = daemon::parse_config("[[device]]\nname = \"counter\"\ndriver = \"counting\"\n"
                                     "[[processing]]\ndevice = \"counter\"\nchannel = \"bar\"\n",
                                     "bad.toml");
  const auto devices = daemon::create_devices(config, registry);
  try {
    (void)daemon::processing_steps(config, devices);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.toml:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("has no channel \"bar\" (it has: count)"), std::string::npos) << e.what();
  }
}

TEST(Daemon, DropsAClientThatNeverReadsAndKeepsServingOthers) {
  RunningDaemon rd(
      "sample_publish_hz = 100000.0\n[[device]]\nname = \"counter\"\ndriver = \"counting\"\nrate_hz = 50000.0\n");
  // A raw client that subscribes to SAMPLE and then never reads.
  const int silent = socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strcpy(addr.sun_path, rd.socket.c_str());
  ASSERT_EQ(connect(silent, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  const std::string watch = "{\"class\":\"watch\",\"classes\":[\"SAMPLE\"]}\n";
  ASSERT_EQ(write(silent, watch.data(), watch.size()), static_cast<ssize_t>(watch.size()));

  DaemonClient good(rd.socket);
  EXPECT_TRUE(test::eventually(
      [&] {
        auto s = good.request({{"class", "status"}}, guideway::results::MessageClass::status);
        return s["clients"]["dropped_slow"].get<int>() >= 1;
      },
      std::chrono::seconds(20)));
  auto s = good.request({{"class", "status"}}, guideway::results::MessageClass::status);
  EXPECT_EQ(s["clients"]["connected"], 1);
  EXPECT_EQ(s["devices"][0]["state"], "streaming");
  close(silent);
}

TEST(Daemon, UnknownDriverIsAConfigErrorNamingTheKnownOnes) {
  test::TempDir dir;
  drivers::DriverRegistry registry;
  registry.add("counting", "test", [](const drivers::DeviceConfig& c) { return std::make_unique<test::CountingDriver>(c); });
  auto config = daemon::parse_config("[daemon]\nsocket = \"" + dir.file("s") +
                                         "\"\n[[device]]\nname = \"x\"\ndriver = \"nope\"\n",
                                     "bad.toml");
  auto log = std::make_shared<spdlog::logger>("test", std::make_shared<spdlog::sinks::null_sink_mt>());
  try {
    sessions::SessionRegistry sessions;
    daemon::Daemon d(std::move(config), registry, sessions, log);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.toml:5: device[0].driver: unknown driver \"nope\" (known: counting)"),
              std::string::npos)
        << e.what();
  }
}

TEST(Daemon, UnknownKeyInADeviceTableIsRejected) {
  test::TempDir dir;
  drivers::DriverRegistry registry;
  registry.add("counting", "test", [](const drivers::DeviceConfig& c) { return std::make_unique<test::CountingDriver>(c); });
  auto config = daemon::parse_config("[daemon]\nsocket = \"" + dir.file("s") +
                                         "\"\n[[device]]\nname = \"x\"\ndriver = \"counting\"\nrate_hx = 5.0\n",
                                     "bad.toml");
  auto log = std::make_shared<spdlog::logger>("test", std::make_shared<spdlog::sinks::null_sink_mt>());
  sessions::SessionRegistry sessions;
  EXPECT_THROW(daemon::Daemon(std::move(config), registry, sessions, log), ConfigError);
}

TEST(Daemon, RefusesToStealTheSocketOfALiveDaemon) {
  RunningDaemon rd;
  auto config = daemon::parse_config("[daemon]\nsocket = \"" + rd.socket + "\"\n", "t.toml");
  drivers::DriverRegistry registry;
  auto log = std::make_shared<spdlog::logger>("test", std::make_shared<spdlog::sinks::null_sink_mt>());
  try {
    sessions::SessionRegistry sessions;
    daemon::Daemon second(std::move(config), registry, sessions, log);
    FAIL() << "a second daemon bound the same socket";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("already listening"), std::string::npos);
  }
  DaemonClient c(rd.socket);  // the first one still answers
  EXPECT_EQ(c.banner()["class"], "VERSION");
}

// Two daemons starting at once can both find nobody answering on the path (the first has not bound
// it yet): the instance lock, taken before anything starts, keeps the second out all the same.
TEST(Daemon, TheInstanceLockKeepsASecondDaemonOutBeforeTheSocketAnswers) {
  RunningDaemon rd;
  const std::string moved = rd.socket + ".moved";
  ASSERT_EQ(std::rename(rd.socket.c_str(), moved.c_str()), 0);  // nobody answers on the path now
  auto config = daemon::parse_config("[daemon]\nsocket = \"" + rd.socket + "\"\n", "t.toml");
  drivers::DriverRegistry registry;
  auto log = std::make_shared<spdlog::logger>("test", std::make_shared<spdlog::sinks::null_sink_mt>());
  try {
    sessions::SessionRegistry sessions;
    daemon::Daemon second(std::move(config), registry, sessions, log);
    FAIL() << "a second daemon started while the first held the lock";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(".lock"), std::string::npos) << e.what();
  }
  ASSERT_EQ(std::rename(moved.c_str(), rd.socket.c_str()), 0);
  DaemonClient c(rd.socket);
  EXPECT_EQ(c.banner()["class"], "VERSION");
}
