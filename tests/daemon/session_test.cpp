// Sessions end to end in-process: start over the socket, samples from a real driver thread through
// the pipeline into the session and its raw recording, identification on the worker thread, PARAMS
// published and cached for `params`, the recording fsynced and renamed with its end marker.
#include <gtest/gtest.h>
#include <spdlog/sinks/null_sink.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include <unistd.h>

#include <csignal>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <thread>

#include "cli/daemon_client.hpp"
#include "core/mono_clock.hpp"
#include "daemon/daemon.hpp"
#include "daemon/session_analysis.hpp"
#include "formats/raw_recording.hpp"
#include "sessions/recorder.hpp"
#include "counting_driver.hpp"
#include "test_support.hpp"

using namespace guideway;
using guideway::cli::DaemonClient;

namespace {

// While set, a MeanSession's identification waits (at most 20 s): a session held in `finishing`.
std::atomic<bool> hold_identification{false};

// Collects N samples (or until stopped) and identifies their mean and count; refuses fewer than 2.
class MeanSession : public sessions::Session {
 public:
  explicit MeanSession(std::size_t wanted) : wanted_(wanted) {}
  void on_samples(std::span<const Sample> samples) override {
    for (const Sample& s : samples) {
      if (wanted_ == 0 || values_.size() < wanted_) values_.push_back(s.value[0]);
    }
  }
  [[nodiscard]] bool complete() const override { return wanted_ != 0 && values_.size() >= wanted_; }
  [[nodiscard]] std::string progress() const override { return std::to_string(values_.size()) + " samples"; }
  results::Params identify() override {
    test::eventually([] { return !hold_identification.load(); }, std::chrono::seconds(20));
    if (values_.size() < 2) throw std::runtime_error("too few samples (" + std::to_string(values_.size()) + ")");
    double sum = 0;
    for (double v : values_) sum += v;
    results::Params p;
    p.model = "mean";
    p.groups.push_back(
        {"parameters",
         {results::figure("mean", sum / static_cast<double>(values_.size()), std::nullopt, "parameters")}});
    p.record = {{"first", values_.front()}, {"last", values_.back()}, {"n", values_.size()}};
    return p;
  }
  [[nodiscard]] std::map<std::string, std::string> metadata() const override {
    return {{"wanted", std::to_string(wanted_)}};
  }

 protected:
  std::size_t wanted_;
  std::vector<double> values_;
};

// A MeanSession identified from its derived file (its values, one a line), as a DBB session is from its run
// files: with [daemon] session_analysis = "process" the daemon identifies it in a process of its own. Its
// PARAMS say which process identified it (record "pid").
class DerivedMeanSession : public MeanSession {
 public:
  using MeanSession::MeanSession;
  results::Params identify() override {
    results::Params p = MeanSession::identify();
    p.record["pid"] = static_cast<long>(getpid());
    return p;
  }
  std::vector<std::string> write_derived(const std::string& dir, const std::string& base_name) override {
    const std::string path = dir + "/" + base_name + ".values.txt";
    std::ofstream out(path);
    out.precision(17);
    for (const double v : values_) out << v << "\n";
    return {path};
  }
  [[nodiscard]] bool identifies_from_derived() const override { return true; }
  void read_derived(const std::vector<std::string>& paths) override {
    for (const auto& path : paths) {
      std::ifstream in(path);
      for (double v = 0; in >> v;) values_.push_back(v);
    }
  }
};

void add_test_kinds(sessions::SessionRegistry& kinds) {
  kinds.add({"mean", "test mean", {"counting"}, [](const sessions::SessionRequest& r, const drivers::Driver&) {
               const auto n = r.options.value("samples", 0);
               if (n < 0) throw std::invalid_argument("samples must be >= 0");
               return std::make_unique<MeanSession>(static_cast<std::size_t>(n));
             },
             {}});
  kinds.add({"dmean", "test mean from its derived file", {"counting"},
             [](const sessions::SessionRequest& r, const drivers::Driver&) -> std::unique_ptr<sessions::Session> {
               return std::make_unique<DerivedMeanSession>(static_cast<std::size_t>(r.options.value("samples", 0)));
             },
             {}});
}

// This test's own program is the analysis process of the daemons it runs with session_analysis = "process":
// `session_test --analyse-session` answers as guidewayd's would, with the kinds above, before gtest sees the
// flag.
const bool is_analysis_process = [] {
  std::ifstream in("/proc/self/cmdline");
  const std::string args((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (args.find(std::string("\0--analyse-session", 18)) == std::string::npos) return false;
  sessions::SessionRegistry kinds;
  add_test_kinds(kinds);
  std::exit(daemon::run_session_analysis(std::cin, std::cout, kinds, {}));
}();

std::string self_executable() { return std::filesystem::read_symlink("/proc/self/exe").string(); }

struct Fixture {
  // daemon_keys: more lines of its [daemon] table.
  explicit Fixture(const std::string& state_dir = "", const std::string& daemon_keys = "") {
    registry.add("counting", "test", [](const drivers::DeviceConfig& c) { return std::make_unique<test::CountingDriver>(c); });
    add_test_kinds(sessions);
    socket = dir.file("s.sock");
    state = state_dir.empty() ? dir.file("state") : state_dir;
    auto config = daemon::parse_config("[daemon]\nsocket = \"" + socket + "\"\nstate_dir = \"" + state +
                                           "\"\nstatus_period_s = 0.1\n" + daemon_keys +
                                           "[[device]]\nname = \"c\"\ndriver = \"counting\"\n",
                                       "t.toml");
    auto log = std::make_shared<spdlog::logger>("t", std::make_shared<spdlog::sinks::null_sink_mt>());
    d = std::make_unique<daemon::Daemon>(std::move(config), registry, sessions, log);
    thread = std::thread([this] { d->run(); });
  }
  ~Fixture() {
    d->request_stop();
    thread.join();
  }
  // Waits for the next published message of class cls.
  static nlohmann::json next(DaemonClient& c, const std::string& cls) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline) {
      auto line = c.read_line(std::chrono::milliseconds(200));
      if (!line) continue;
      auto j = nlohmann::json::parse(*line);
      if (j["class"] == cls) return j;
    }
    return {};
  }
  test::TempDir dir;
  drivers::DriverRegistry registry;
  sessions::SessionRegistry sessions;
  std::string socket;
  std::string state;
  std::unique_ptr<daemon::Daemon> d;
  std::thread thread;
};

std::vector<std::string> read_lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

}  // namespace

TEST(Session, CompletesIdentifiesPublishesAndRecordsEverySample) {
  Fixture f;
  DaemonClient c(f.socket);
  c.request({{"class", "watch"}, {"classes", {"PARAMS", "EVENT"}}}, guideway::results::MessageClass::watch);
  auto started = c.request({{"class", "start"}, {"kind", "mean"}, {"options", {{"samples", 400}}}},
                           guideway::results::MessageClass::session);
  ASSERT_EQ(started["class"], "SESSION") << started.dump();
  const std::string name = started["session"];
  EXPECT_EQ(name.rfind("mean-c-", 0), 0u);

  const auto params = Fixture::next(c, "PARAMS");
  ASSERT_FALSE(params.is_null());
  EXPECT_EQ(params["session"], name);
  EXPECT_EQ(params["n"], 400);
  const double first = params["first"], last = params["last"];
  EXPECT_DOUBLE_EQ(last - first, 399.0);  // consecutive: nothing lost between ring and session
  EXPECT_DOUBLE_EQ(params["parameters"]["mean"]["value"].get<double>(), (first + last) / 2);

  // The recording: renamed into place, header, every sample in order, end marker.
  const std::string path = params["recording"];
  EXPECT_EQ(path, f.state + "/" + name + ".csv");
  const auto lines = read_lines(path);
  ASSERT_GT(lines.size(), 10u);
  EXPECT_EQ(lines[0], "# format = guideway/raw/1");
  auto header = std::find(lines.begin(), lines.end(), "t_mono_ns,seq,flags,count_1");
  ASSERT_NE(header, lines.end());
  std::vector<double> counts;
  std::int64_t last_t = 0;
  for (auto it = header + 1; it != lines.end() && (*it)[0] != '#'; ++it) {
    const auto c1 = it->find(','), c2 = it->find(',', c1 + 1), c3 = it->find(',', c2 + 1);
    const std::int64_t t = std::stoll(it->substr(0, c1));
    EXPECT_GE(t, last_t);
    last_t = t;
    counts.push_back(std::stod(it->substr(c3 + 1)));
  }
  ASSERT_GE(counts.size(), 400u);
  EXPECT_DOUBLE_EQ(counts.front(), first);
  for (std::size_t i = 1; i < counts.size(); ++i) ASSERT_DOUBLE_EQ(counts[i], counts[i - 1] + 1) << "row " << i;
  EXPECT_NE(std::find(lines.begin(), lines.end(), "# end = complete"), lines.end());
  EXPECT_NE(std::find(lines.begin(), lines.end(), "# wanted = 400"), lines.end());

  // params returns the cached result; recordings lists the file.
  auto cached = c.request({{"class", "params"}, {"kind", "mean"}}, guideway::results::MessageClass::params);
  EXPECT_EQ(cached["session"], name);
  // A session's derived files are CSV beside the recording, but they are not raw recordings.
  std::ofstream(f.state + "/" + name + ".run1.csv") << "# format = guideway/dbb-run/1\nangle_deg,dr_um\n";
  auto recs = c.request({{"class", "recordings"}}, guideway::results::MessageClass::recordings);
  ASSERT_EQ(recs["recordings"].size(), 1u) << recs.dump();
  EXPECT_EQ(recs["recordings"][0]["file"], path);
  EXPECT_EQ(recs["recordings"][0]["complete"], true);
}

TEST(Session, StopEndsAnOpenEndedSessionAndStatusShowsIt) {
  Fixture f;
  DaemonClient c(f.socket);
  c.request({{"class", "watch"}, {"classes", {"PARAMS"}}}, guideway::results::MessageClass::watch);
  const std::string name =
      c.request({{"class", "start"}, {"kind", "mean"}}, guideway::results::MessageClass::session)["session"];
  EXPECT_TRUE(test::eventually([&] {
    auto s = c.request({{"class", "status"}}, guideway::results::MessageClass::status);
    return s["sessions"].size() == 1 && s["sessions"][0]["state"] == "running" && s["sessions"][0]["samples"] > 50;
  }));
  // The device is busy: a second session on it is refused.
  auto busy = c.request({{"class", "start"}, {"kind", "mean"}}, guideway::results::MessageClass::session);
  EXPECT_EQ(busy["class"], "ERROR");
  auto stopped = c.request({{"class", "stop"}, {"session", name}}, guideway::results::MessageClass::session);
  EXPECT_EQ(stopped["state"], "finishing");
  const auto params = Fixture::next(c, "PARAMS");
  EXPECT_EQ(params["session"], name);
  EXPECT_GT(params["n"].get<int>(), 50);
}

// A LinuxCNC program that runs two tests back to back starts the second while the first is identified:
// a session that is finishing has its samples and no longer holds its device (it was refused as busy).
TEST(Session, ASessionBeingIdentifiedLeavesItsDeviceToTheNext) {
  Fixture f;
  DaemonClient c(f.socket);
  c.request({{"class", "watch"}, {"classes", {"PARAMS"}}}, guideway::results::MessageClass::watch);
  hold_identification = true;
  const std::string first =
      c.request({{"class", "start"}, {"kind", "mean"}, {"options", {{"samples", 100}}}},
                guideway::results::MessageClass::session)["session"];
  ASSERT_TRUE(test::eventually([&] {
    auto s = c.request({{"class", "status"}}, guideway::results::MessageClass::status);
    return s["sessions"].size() == 1 && s["sessions"][0]["state"] == "finishing";
  }));
  const auto second = c.request({{"class", "start"}, {"kind", "mean"}}, guideway::results::MessageClass::session);
  hold_identification = false;
  ASSERT_EQ(second["class"], "SESSION") << second.dump();
  EXPECT_NE(second["session"], first);
  const auto first_params = Fixture::next(c, "PARAMS");
  EXPECT_EQ(first_params["session"], first);
  EXPECT_EQ(first_params["n"], 100);
  EXPECT_TRUE(test::eventually([&] {
    auto s = c.request({{"class", "status"}}, guideway::results::MessageClass::status);
    for (const auto& i : s["sessions"])
      if (i["session"] == second["session"]) return i["state"] == "running" && i["samples"] > 50;
    return false;
  })) << "the second session records";
  c.request({{"class", "stop"}, {"session", second["session"]}}, guideway::results::MessageClass::session);
  const auto second_params = Fixture::next(c, "PARAMS");
  EXPECT_EQ(second_params["session"], second["session"]);
  EXPECT_GT(second_params["n"].get<int>(), 50);
}

// protocol.md: watch "channels: device or session names". A session's PARAMS and EVENTs reach a client
// that watches the session by name (they are published about the device too).
TEST(Session, WatchingASessionByNameGetsItsParams) {
  Fixture f;
  DaemonClient c(f.socket);
  const std::string name =
      c.request({{"class", "start"}, {"kind", "mean"}}, guideway::results::MessageClass::session)["session"];
  DaemonClient by_session(f.socket), other(f.socket);
  by_session.request({{"class", "watch"}, {"classes", {"PARAMS"}}, {"channels", {name}}},
                     guideway::results::MessageClass::watch);
  other.request({{"class", "watch"}, {"classes", {"PARAMS"}}, {"channels", {"mean-c-other"}}},
                guideway::results::MessageClass::watch);
  EXPECT_TRUE(test::eventually([&] {
    return c.request({{"class", "status"}}, guideway::results::MessageClass::status)["sessions"][0]["samples"]
               .get<std::uint64_t>() > 10;
  }));
  c.request({{"class", "stop"}}, guideway::results::MessageClass::session);
  const auto params = Fixture::next(by_session, "PARAMS");
  ASSERT_FALSE(params.is_null());
  EXPECT_EQ(params["session"], name);
  EXPECT_FALSE(other.read_line(std::chrono::milliseconds(300)).has_value());  // another session's name: nothing
}

TEST(Session, BadRequestsGetErrorsAndTheDaemonGoesOn) {
  Fixture f;
  DaemonClient c(f.socket);
  EXPECT_NE(
      c.request({{"class", "start"}}, guideway::results::MessageClass::session)["message"].get<std::string>().find(
          "needs \"kind\""),
      std::string::npos);
  EXPECT_NE(c.request({{"class", "start"}, {"kind", "nope"}}, guideway::results::MessageClass::session)["message"]
                .get<std::string>()
                .find("unknown session kind \"nope\" (known: mean, dmean)"),
            std::string::npos);
  EXPECT_NE(c.request({{"class", "start"}, {"kind", "mean"}, {"device", "zz"}},
                      guideway::results::MessageClass::session)["message"]
                .get<std::string>()
                .find("no device named"),
            std::string::npos);
  EXPECT_EQ(c.request({{"class", "start"}, {"kind", "mean"}, {"options", {{"samples", -3}}}},
                      guideway::results::MessageClass::session)["message"],
            "samples must be >= 0");
  EXPECT_EQ(c.request({{"class", "stop"}}, guideway::results::MessageClass::session)["message"],
            "no session is running");
  EXPECT_NE(
      c.request({{"class", "params"}}, guideway::results::MessageClass::params)["message"].get<std::string>().find(
          "no parameters"),
      std::string::npos);
  // The device still streams. Its driver thread may not have run yet when these requests are answered
  // (the state is "connecting" until it does): waited for, not assumed.
  EXPECT_TRUE(test::eventually([&] {
    return c.request({{"class", "status"}}, guideway::results::MessageClass::status)["devices"][0]["state"] ==
           "streaming";
  }));
}

TEST(Session, UnwritableStateDirIsReportedAndIdentificationGoesOn) {
  test::TempDir blocker;
  const std::string file_not_dir = blocker.file("plain-file");
  std::ofstream(file_not_dir) << "x";
  Fixture f(file_not_dir + "/state");  // a directory below a regular file cannot be created
  DaemonClient c(f.socket);
  c.request({{"class", "watch"}, {"classes", {"PARAMS", "EVENT"}}}, guideway::results::MessageClass::watch);
  c.request({{"class", "start"}, {"kind", "mean"}, {"options", {{"samples", 100}}}},
            guideway::results::MessageClass::session);
  bool saw_failure_event = false;
  nlohmann::json params;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (params.is_null() && std::chrono::steady_clock::now() < deadline) {
    auto line = c.read_line(std::chrono::milliseconds(200));
    if (!line) continue;
    auto j = nlohmann::json::parse(*line);
    if (j["class"] == "EVENT" && j["event"] == "recording_failed") saw_failure_event = true;
    if (j["class"] == "PARAMS") params = j;
  }
  EXPECT_TRUE(saw_failure_event);
  ASSERT_FALSE(params.is_null());
  EXPECT_EQ(params["n"], 100);
  EXPECT_FALSE(params.contains("recording"));
}

// A disk that fills up mid-session (here: a file size limit, EFBIG, as ENOSPC would) is reported while
// the session runs: an EVENT, STATUS sessions[].recording_error; the session goes on, identifies
// every sample, and its PARAMS say the recording failed.
TEST(Session, DiskFullMidSessionIsReportedWhileTheSessionRuns) {
  Fixture f;
  DaemonClient c(f.socket);
  c.request({{"class", "watch"}, {"classes", {"PARAMS", "EVENT"}}}, guideway::results::MessageClass::watch);
  std::signal(SIGXFSZ, SIG_IGN);  // a write past the limit fails with EFBIG instead of killing the test
  rlimit old{};
  getrlimit(RLIMIT_FSIZE, &old);
  rlimit small = old;
  small.rlim_cur = 16384;  // the counting driver's 2 kHz fill this in well under a second
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  struct Restore {
    rlimit r;
    ~Restore() { setrlimit(RLIMIT_FSIZE, &r); }
  } restore{old};
  const std::string name =
      c.request({{"class", "start"}, {"kind", "mean"}}, guideway::results::MessageClass::session)["session"];
  nlohmann::json event;
  EXPECT_TRUE(test::eventually([&] {
    auto line = c.read_line(std::chrono::milliseconds(100));
    if (!line) return false;
    auto j = nlohmann::json::parse(*line);
    if (j["class"] == "EVENT" && j["event"] == "recording_failed") event = j;
    return !event.is_null();
  }));
  EXPECT_EQ(event["session"], name);
  EXPECT_NE(event.value("reason", "").find(name + ".csv.part"), std::string::npos) << event.dump();
  // Reported while the session still runs, and the session still gets samples.
  auto status = c.request({{"class", "status"}}, guideway::results::MessageClass::status);
  ASSERT_EQ(status["sessions"].size(), 1u);
  EXPECT_EQ(status["sessions"][0]["state"], "running");
  EXPECT_NE(status["sessions"][0].value("recording_error", "").find(".csv.part"), std::string::npos) << status.dump();
  const std::uint64_t before = status["sessions"][0]["samples"];
  EXPECT_TRUE(test::eventually([&] {
    return c.request({{"class", "status"}}, guideway::results::MessageClass::status)["sessions"][0]["samples"]
               .get<std::uint64_t>() > before + 200;
  }));
  c.request({{"class", "stop"}}, guideway::results::MessageClass::session);
  const auto params = Fixture::next(c, "PARAMS");
  ASSERT_FALSE(params.is_null());
  EXPECT_GT(params["n"].get<std::uint64_t>(), before + 200);
  EXPECT_NE(params.value("recording_error", "").find(".csv.part"), std::string::npos) << params.dump();
  EXPECT_EQ(params.value("recording", ""), f.state + "/" + name + ".csv.part");  // left incomplete
  // Its files could not be written: the session still ends with a report event, report_failed saying
  // why (a client waiting for report_ready or report_failed hung before).
  const auto report = Fixture::next(c, "EVENT");
  ASSERT_FALSE(report.is_null());
  EXPECT_EQ(report["event"], "report_failed") << report.dump();
  EXPECT_EQ(report["session"], name);
  EXPECT_NE(report.value("reason", "").find("no report"), std::string::npos) << report.dump();
}

TEST(Session, FailedIdentificationIsAnEventWithTheReason) {
  Fixture f;
  DaemonClient c(f.socket);
  c.request({{"class", "watch"}, {"classes", {"EVENT"}}}, guideway::results::MessageClass::watch);
  c.request({{"class", "start"}, {"kind", "mean"}, {"options", {{"samples", 1}}}},
            guideway::results::MessageClass::session);
  nlohmann::json ev;
  EXPECT_TRUE(test::eventually([&] {
    auto line = c.read_line(std::chrono::milliseconds(100));
    if (!line) return false;
    auto j = nlohmann::json::parse(*line);
    if (j["class"] == "EVENT" && j["event"] == "session_failed") ev = j;
    return !ev.is_null();
  }));
  EXPECT_EQ(ev["reason"], "too few samples (1)");
  // ... and, as every session, one report event: report_failed with the reason.
  const auto report = Fixture::next(c, "EVENT");
  ASSERT_FALSE(report.is_null());
  EXPECT_EQ(report["event"], "report_failed") << report.dump();
  EXPECT_NE(report.value("reason", "").find("identification failed: too few samples (1)"), std::string::npos);
  // params names the failed session and why, rather than "start a session".
  const std::string message =
      c.request({{"class", "params"}, {"kind", "mean"}}, guideway::results::MessageClass::params)["message"];
  EXPECT_NE(message.find("session " + ev["session"].get<std::string>() + " failed: too few samples (1)"),
            std::string::npos)
      << message;
}

TEST(RawRecorder, SamplesTheRingDroppedAreCountedOnceInTheTrailer) {
  test::TempDir dir;
  const toml::table empty;
  const TableReader table(empty, "test.toml", "device");
  const test::CountingDriver device({.name = "c", .driver = "counting", .ring_capacity = {}, .table = table});
  // A ring of 4 and a writer that sleeps: 10 samples pushed at once, 6 of them cannot be kept.
  sessions::RawRecorder recorder(dir.path().string(), "lost", device, {{"kind", "test"}},
                                 {.flush_period = std::chrono::seconds(1), .ring_capacity = 4});
  std::vector<Sample> samples(10);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    samples[i].seq = i;
    samples[i].value_count = 1;
    samples[i].value[0] = static_cast<double>(i);
  }
  recorder.push(samples);
  const std::string path = recorder.close(true);
  EXPECT_EQ(recorder.stats().samples_written, 4u);
  EXPECT_EQ(recorder.stats().samples_lost, 6u);
  const formats::RawRecording back = formats::read_raw_recording(path);
  EXPECT_EQ(back.samples.size(), 4u);
  EXPECT_EQ(back.samples_lost, 6u) << "the trailer counts each dropped sample once";
  EXPECT_FALSE(back.complete) << "a recording that lost samples is not whole";
}

// A recorder's ring is as large as its device's (8 s of the device's full rate, drivers/ring_capacity.hpp), not a
// fixed 65,536 samples held for every session: one sample more than that, pushed at once before the writer wakes,
// is lost and counted.
TEST(RawRecorder, ItsRingIsAsLargeAsItsDevicesRing) {
  test::TempDir dir;
  const toml::table empty;
  const TableReader table(empty, "test.toml", "device");
  const test::CountingDriver device({.name = "c", .driver = "counting", .ring_capacity = {}, .table = table});
  ASSERT_EQ(device.ring_capacity(), 16384u) << "2 kHz: 8 s is 16,000 samples, the next power of two";
  sessions::RawRecorder recorder(dir.path().string(), "sized", device, {{"kind", "test"}},
                                 {.flush_period = std::chrono::seconds(3)});
  std::vector<Sample> samples(device.ring_capacity() + 1);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    samples[i].seq = i;
    samples[i].value_count = 1;
    samples[i].value[0] = static_cast<double>(i);
  }
  recorder.push(samples);
  recorder.close(true);
  EXPECT_EQ(recorder.stats().samples_written, device.ring_capacity());
  EXPECT_EQ(recorder.stats().samples_lost, 1u);
}

// A session identified from its derived files is identified, explained and reported in a process of its own
// ([daemon] session_analysis = "process"): the PARAMS are those the daemon would publish, made in another
// process; with session_analysis = "daemon", in the daemon's.
TEST(SessionAnalysis, ASessionIdentifiedFromItsFilesIsIdentifiedInAProcessOfItsOwn) {
  for (const bool in_process : {true, false}) {
    SCOPED_TRACE(in_process ? "process" : "daemon");
    Fixture f("", in_process ? "analysis_executable = \"" + self_executable() + "\"\n"
                             : "session_analysis = \"daemon\"\nanalysis_executable = \"" + self_executable() + "\"\n");
    DaemonClient c(f.socket);
    c.request({{"class", "watch"}, {"classes", {"PARAMS", "EVENT"}}}, guideway::results::MessageClass::watch);
    c.request({{"class", "start"}, {"kind", "dmean"}, {"options", {{"samples", 300}}}},
              guideway::results::MessageClass::session);
    const auto params = Fixture::next(c, "PARAMS");
    ASSERT_FALSE(params.is_null());
    EXPECT_EQ(params["n"], 300);
    const double first = params["first"], last = params["last"];
    EXPECT_DOUBLE_EQ(last - first, 299.0);
    EXPECT_DOUBLE_EQ(params["parameters"]["mean"]["value"].get<double>(), (first + last) / 2);
    ASSERT_TRUE(params.contains("pid")) << params.dump();
    if (in_process)
      EXPECT_NE(params["pid"].get<long>(), static_cast<long>(getpid()));
    else
      EXPECT_EQ(params["pid"].get<long>(), static_cast<long>(getpid()));
    // Its derived file is published with it; the report fails as without a renderer, saying why.
    ASSERT_EQ(params["derived"].size(), 1u) << params.dump();
    const auto report = Fixture::next(c, "EVENT");
    EXPECT_EQ(report.value("event", ""), "report_failed") << report.dump();
    EXPECT_NE(report.value("reason", "").find("without the report renderer"), std::string::npos) << report.dump();
  }
}

// An analysis process that crashes, exits or answers what is not JSON fails its session with a reason that says
// so; the daemon goes on (the next session starts, and fails the same way).
TEST(SessionAnalysis, AnAnalysisProcessThatFailsIsASessionErrorAndTheDaemonGoesOn) {
  const struct {
    const char* script;
    const char* reason;
  } cases[] = {{"kill -SEGV $$\n", "killed by signal 11"},
               {"exit 3\n", "exit status 3"},
               {"echo 'no JSON'\nexec sleep 1\n", "answered what is not a JSON object: \"no JSON\""}};
  for (const auto& k : cases) {
    SCOPED_TRACE(k.script);
    test::TempDir scripts;
    const std::string exe = scripts.file("analyse");
    std::ofstream(exe) << "#!/bin/sh\n" << k.script;
    ::chmod(exe.c_str(), 0755);
    Fixture f("", "analysis_executable = \"" + exe + "\"\n");
    DaemonClient c(f.socket);
    c.request({{"class", "watch"}, {"classes", {"EVENT"}}}, guideway::results::MessageClass::watch);
    for (int session = 0; session < 2; ++session) {
      const auto started = c.request({{"class", "start"}, {"kind", "dmean"}, {"options", {{"samples", 50}}}},
                                     guideway::results::MessageClass::session);
      ASSERT_EQ(started["class"], "SESSION") << started.dump();
      nlohmann::json failed;
      for (int i = 0; i < 4 && failed.is_null(); ++i) {
        const auto ev = Fixture::next(c, "EVENT");
        ASSERT_FALSE(ev.is_null());
        if (ev["event"] == "session_failed") failed = ev;
      }
      ASSERT_FALSE(failed.is_null());
      EXPECT_EQ(failed["session"], started["session"]);
      const std::string reason = failed["reason"];
      EXPECT_NE(reason.find("the session's analysis process (" + exe + " --analyse-session, pid "), std::string::npos)
          << reason;
      EXPECT_NE(reason.find(k.reason), std::string::npos) << reason;
      // STATUS shows it failed.
      EXPECT_TRUE(test::eventually([&] {
        auto s = c.request({{"class", "status"}}, guideway::results::MessageClass::status);
        for (const auto& x : s["sessions"])
          if (x["session"] == started["session"]) return x["state"] == "failed";
        return false;
      }));
    }
  }
}
