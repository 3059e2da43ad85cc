// N daemons' MQTT publishers in one process (bench/README.md, "Plant"): N plant::Publisher instances,
// the daemon's exact publisher code, each its own machine `bench-NN` and its own journal directory,
// each handed M messages at a given rate: one session's PARAMS, EXPLAIN and report_ready EVENT after
// another, the golden results of the four session kinds (tests/golden/KIND.{params,explain}.json) with
// their session changed so that every message is distinct. Then it waits until every publisher's
// queue is empty and prints one JSON object: messages, delivered, dropped, times, the process's CPU
// (getrusage) and what Publisher::publish() costs its caller (the daemon's event loop), p50/p99/max.
//
//   plant_publishers --broker mqtt://127.0.0.1:PORT [--publishers 50] [--messages 200] [--rate-hz 20]
//                    [--topic-prefix guideway] [--run-id ID] [--timeout-s 300]
#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>
#include <nlohmann/json.hpp>

#include "core/mono_clock.hpp"
#include "core/utc_time.hpp"
#include "plant/broker_address.hpp"
#include "plant/publisher.hpp"
#include "results/message_class.hpp"

using namespace guideway;

namespace {

namespace fs = std::filesystem;

struct Options {
  std::string broker;
  int publishers = 50;
  int messages = 200;     // per publisher
  double rate_hz = 20.0;  // per publisher; 0 = as fast as publish() returns
  std::string topic_prefix = "guideway";
  std::string run_id = utc_now("%Y%m%dT%H%M%SZ");  // in every session name: runs into one database stay distinct
  double timeout_s = 300.0;                        // for the connections, then for the queues to empty
};

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(
      stderr,
      "plant_publishers: %s\nusage: plant_publishers --broker mqtt://HOST:PORT [--publishers N] [--messages M] "
      "[--rate-hz HZ] [--topic-prefix P] [--run-id ID] [--timeout-s S]\n",
      why.c_str());
  std::exit(2);
}

Options parse_options(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) usage(a + " needs a value");
    const std::string v = argv[++i];
    if (a == "--broker")
      o.broker = v;
    else if (a == "--publishers")
      o.publishers = std::atoi(v.c_str());
    else if (a == "--messages")
      o.messages = std::atoi(v.c_str());
    else if (a == "--rate-hz")
      o.rate_hz = std::atof(v.c_str());
    else if (a == "--topic-prefix")
      o.topic_prefix = v;
    else if (a == "--run-id")
      o.run_id = v;
    else if (a == "--timeout-s")
      o.timeout_s = std::atof(v.c_str());
    else
      usage("unknown option " + a);
  }
  if (o.broker.empty()) usage("--broker is required");
  if (o.publishers < 1 || o.messages < 1 || o.rate_hz < 0) usage("--publishers and --messages >= 1, --rate-hz >= 0");
  return o;
}

// A golden result as the daemon sends it (one compact line), split around its session's value.
struct Template {
  std::string kind;
  std::string head, tail;
  [[nodiscard]] std::string with_session(const std::string& session) const { return head + session + tail; }
};

Template golden(const std::string& file, const std::string& kind) {
  std::ifstream in(std::string(GUIDEWAY_SOURCE_DIR) + "/tests/golden/" + file);
  if (!in) throw std::runtime_error("cannot read tests/golden/" + file);
  nlohmann::json j = nlohmann::json::parse(in);
  const std::string marker = "@@plant-publishers-session@@";  // JSON keeps it as it is
  j["session"] = marker;
  const std::string text = j.dump();
  const auto at = text.find(marker);
  if (at == std::string::npos) throw std::logic_error("the session marker is not in " + file);
  return {kind, text.substr(0, at), text.substr(at + marker.size())};
}

// One session's messages, in the order the daemon sends them.
struct Session {
  Template params, explain;
};

std::vector<Session> golden_sessions() {
  std::vector<Session> s;
  for (const char* kind : {"dbb", "runout", "profile", "straightness"}) {
    const std::string k = kind;
    s.push_back({golden(k + ".params.json", k), golden(k + ".explain.json", k)});
  }
  return s;
}

struct Percentiles {
  std::int64_t p50 = 0, p99 = 0, max = 0;
};

Percentiles percentiles(std::vector<std::int64_t> v) {
  if (v.empty()) return {};
  std::sort(v.begin(), v.end());
  const auto at = [&](double q) {
    return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
  };
  return {at(0.5), at(0.99), v.back()};
}

nlohmann::json to_json(const Percentiles& p) { return {{"p50", p.p50}, {"p99", p.p99}, {"max", p.max}}; }

double cpu_s(int who, double* user = nullptr, double* system = nullptr) {
  rusage r{};
  getrusage(who, &r);
  const double u = static_cast<double>(r.ru_utime.tv_sec) + static_cast<double>(r.ru_utime.tv_usec) * 1e-6;
  const double s = static_cast<double>(r.ru_stime.tv_sec) + static_cast<double>(r.ru_stime.tv_usec) * 1e-6;
  if (user) *user = u;
  if (system) *system = s;
  return u + s;
}

void sleep_until_ns(std::int64_t t_ns) {
  const timespec ts{static_cast<time_t>(t_ns / 1'000'000'000), static_cast<long>(t_ns % 1'000'000'000)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) != 0) {
  }
}

// Polls every publisher's stats until `done` holds for all of them or the deadline passes.
template <class Done>
bool wait_all(const std::vector<std::unique_ptr<plant::Publisher>>& pubs, std::int64_t deadline_ns, Done done) {
  while (true) {
    if (std::all_of(pubs.begin(), pubs.end(), [&](const auto& p) { return done(p->stats()); })) return true;
    if (mono_now_ns() > deadline_ns) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse_options(argc, argv);
  const std::vector<Session> sessions = golden_sessions();
  auto sink = std::make_shared<spdlog::sinks::stderr_sink_mt>();
  auto log = std::make_shared<spdlog::logger>("plant_publishers", sink);
  log->set_level(spdlog::level::warn);

  std::string root = (fs::temp_directory_path() / "plant-publishers-XXXXXX").string();  // the journals
  if (mkdtemp(root.data()) == nullptr) {
    std::perror("mkdtemp");
    return 1;
  }

  const auto n = static_cast<std::size_t>(o.publishers);
  std::vector<std::unique_ptr<plant::Publisher>> pubs;
  std::vector<std::string> machines;
  for (std::size_t i = 0; i < n; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "bench-%02zu", i);
    plant::PublisherSettings s;
    s.connection.broker = plant::parse_broker_url(o.broker);
    s.connection.client_id = std::string("guidewayd-") + name;
    s.machine = name;
    s.topic_prefix = o.topic_prefix;
    s.journal_dir = root + "/" + name + "/mqtt-journal";  // as guidewayd: STATE_DIR/mqtt-journal
    s.release = "plant_publishers";
    machines.push_back(name);
    pubs.push_back(std::make_unique<plant::Publisher>(std::move(s), log));
  }
  const std::int64_t timeout_ns = static_cast<std::int64_t>(o.timeout_s * 1e9);
  if (!wait_all(pubs, mono_now_ns() + timeout_ns,
                [](const plant::PublisherStats& s) { return s.state == "connected"; })) {
    std::fprintf(stderr, "plant_publishers: not every publisher connected to %s\n", o.broker.c_str());
    return 1;
  }

  // The caller's side, as the daemon's event loop: one thread hands every publisher its messages,
  // publisher p's message k at (k + p/N) / rate, so the N streams interleave evenly.
  std::vector<std::vector<std::int64_t>> call_ns(n);
  for (auto& v : call_ns) v.reserve(static_cast<std::size_t>(o.messages));
  std::uint64_t payload_bytes = 0;
  double user0 = 0, sys0 = 0;
  const double cpu0 = cpu_s(RUSAGE_SELF, &user0, &sys0);
  const double caller_cpu0 = cpu_s(RUSAGE_THREAD);
  const std::int64_t t0 = mono_now_ns();
  const double period_ns = o.rate_hz > 0 ? 1e9 / (o.rate_hz * static_cast<double>(n)) : 0.0;
  for (int k = 0; k < o.messages; ++k) {
    for (std::size_t p = 0; p < n; ++p) {
      if (period_ns > 0)
        sleep_until_ns(t0 +
                       static_cast<std::int64_t>(period_ns * static_cast<double>(static_cast<std::size_t>(k) * n + p)));
      const int session_no = k / 3;
      const Session& s = sessions[static_cast<std::size_t>(session_no) % sessions.size()];
      const std::string session = machines[p] + "-" + o.run_id + "-" + std::to_string(session_no);
      plant::TopicLeaf leaf = plant::TopicLeaf::event;
      std::string payload;
      switch (k % 3) {
        case 0:
          leaf = plant::TopicLeaf::params;
          payload = s.params.with_session(session);
          break;
        case 1:
          leaf = plant::TopicLeaf::explain;
          payload = s.explain.with_session(session);
          break;
        default:
          payload = results::with_class(results::MessageClass::event,
                                        {{"event", "report_ready"},
                                         {"device", s.params.kind},
                                         {"session", session},
                                         {"file", "/var/lib/guideway/" + session + ".report.html"}})
                        .dump();
      }
      payload_bytes += payload.size();
      const std::string_view kind =
          leaf == plant::TopicLeaf::event ? std::string_view{} : std::string_view{s.params.kind};
      const std::int64_t c0 = mono_now_ns();
      if (leaf == plant::TopicLeaf::event)
        pubs[p]->publish_event(std::move(payload), plant::JournalShare::results, s.params.kind);
      else
        pubs[p]->publish(leaf, kind, std::move(payload));
      call_ns[p].push_back(mono_now_ns() - c0);
    }
  }
  const std::int64_t t_handed = mono_now_ns();
  const double caller_cpu = cpu_s(RUSAGE_THREAD) - caller_cpu0;
  const bool drained =
      wait_all(pubs, mono_now_ns() + timeout_ns, [](const plant::PublisherStats& s) { return s.queued == 0; });
  const std::int64_t t_done = mono_now_ns();
  double user1 = 0, sys1 = 0;
  const double cpu1 = cpu_s(RUSAGE_SELF, &user1, &sys1);

  std::uint64_t delivered = 0, dropped = 0, refused = 0, reconnects = 0, queued = 0;
  nlohmann::json per_publisher = nlohmann::json::array();
  std::vector<std::int64_t> all_calls;
  for (std::size_t p = 0; p < n; ++p) {
    const plant::PublisherStats s = pubs[p]->stats();
    delivered += s.delivered;
    dropped += s.dropped;
    refused += s.refused;
    reconnects += s.reconnects;
    queued += s.queued;
    all_calls.insert(all_calls.end(), call_ns[p].begin(), call_ns[p].end());
    per_publisher.push_back({{"machine", machines[p]},
                             {"delivered", s.delivered},
                             {"dropped", s.dropped},
                             {"publish_call_ns", to_json(percentiles(call_ns[p]))}});
  }
  const std::int64_t t_stop0 = mono_now_ns();
  pubs.clear();  // each publishes its offline status and disconnects
  const double stop_s = static_cast<double>(mono_now_ns() - t_stop0) * 1e-9;
  fs::remove_all(root);

  const double wall_s = static_cast<double>(t_done - t0) * 1e-9;
  const auto messages = static_cast<std::uint64_t>(o.messages) * n;
  std::vector<std::int64_t> worst_p99;
  for (const auto& v : call_ns) worst_p99.push_back(percentiles(v).p99);
  const nlohmann::json out = {
      {"broker", o.broker},
      {"topic_prefix", o.topic_prefix},
      {"run_id", o.run_id},
      {"publishers", n},
      {"messages_per_publisher", o.messages},
      {"rate_hz_per_publisher", o.rate_hz},
      {"messages", messages},
      {"payload_bytes", payload_bytes},
      {"delivered", delivered},
      {"dropped", dropped},
      {"refused", refused},
      {"reconnects", reconnects},
      {"queued_left", queued},
      {"drained", drained},
      {"wall_s", wall_s},
      {"handing_over_s", static_cast<double>(t_handed - t0) * 1e-9},
      {"drain_after_last_s", static_cast<double>(t_done - t_handed) * 1e-9},
      {"delivered_per_s", static_cast<double>(delivered) / wall_s},
      {"stop_s", stop_s},
      {"cpu_s",
       {{"process", cpu1 - cpu0}, {"user", user1 - user0}, {"system", sys1 - sys0}, {"caller_thread", caller_cpu}}},
      {"cpu_pct", 100.0 * (cpu1 - cpu0) / wall_s},
      {"cpu_us_per_message", 1e6 * (cpu1 - cpu0) / static_cast<double>(messages)},
      {"publish_call_ns", to_json(percentiles(all_calls))},
      {"publish_call_ns_worst_publisher_p99", *std::max_element(worst_p99.begin(), worst_p99.end())},
      {"per_publisher", per_publisher}};
  std::printf("%s\n", out.dump(1).c_str());
  return drained && dropped == 0 && refused == 0 ? 0 : 1;
}
