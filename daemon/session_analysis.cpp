// A finished session's analysis in the daemon or in a process of its own (session_analysis.hpp).
#include "daemon/session_analysis.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

#include "core/atomic_file.hpp"
#include "core/utc_time.hpp"
#include "formats/raw_recording.hpp"
#include "sessions/recorder.hpp"
#include "sessions/replay.hpp"

extern char** environ;

namespace guideway::daemon {

namespace {

class InDaemon : public SessionAnalysis {
 public:
  InDaemon(sessions::Session& session, SessionReportRenderer renderer)
      : session_(session), renderer_(std::move(renderer)) {}
  results::Params identify() override { return session_.identify(); }
  std::optional<results::Explanation> explain() override { return session_.explain(); }
  void write_report(const SessionReportRequest& request, const std::string& path) override {
    if (!renderer_) throw std::runtime_error("no report: this daemon was built without the report renderer");
    SessionReportRequest r = request;
    r.session = &session_;
    write_file_atomically(path, renderer_(r), sessions::recording_file_mode);
  }

 private:
  sessions::Session& session_;
  SessionReportRenderer renderer_;
};

// How a child that is gone ended ("exit status 3", "killed by signal 11").
std::string how_it_ended(int status) {
  if (WIFEXITED(status)) return "exit status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return "killed by signal " + std::to_string(WTERMSIG(status));
  return "ended";
}

class InProcess : public SessionAnalysis {
 public:
  InProcess(const std::string& executable, const AnalysisSubject& subject) : executable_(executable) {
    // Its input a socket: a request to a child that died fails with EPIPE (MSG_NOSIGNAL), whoever holds the
    // daemon (a test) and whatever its SIGPIPE.
    int in[2], out[2];
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, in) != 0)
      throw std::runtime_error("socketpair: " + std::string(std::strerror(errno)));
    if (pipe2(out, O_CLOEXEC) != 0) {
      const int err = errno;
      close(in[0]);
      close(in[1]);
      throw std::runtime_error("pipe: " + std::string(std::strerror(err)));
    }
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, in[1], STDIN_FILENO);
    posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
    // The daemon blocks SIGTERM and SIGINT for its signalfd: the child takes them as any program does.
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    sigset_t none;
    sigemptyset(&none);
    posix_spawnattr_setsigmask(&attr, &none);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK);
    std::string arg0 = executable, arg1 = "--analyse-session";
    char* argv[] = {arg0.data(), arg1.data(), nullptr};
    const int rc = posix_spawn(&pid_, executable.c_str(), &actions, &attr, argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    posix_spawnattr_destroy(&attr);
    close(in[1]);
    close(out[1]);
    if (rc != 0) {
      close(in[0]);
      close(out[0]);
      throw std::runtime_error("the session's analysis process (" + executable + ") could not be started: " +
                               std::strerror(rc));
    }
    to_child_ = in[0];
    from_child_ = out[0];
    nlohmann::json channels = nlohmann::json::array();
    for (const auto& c : subject.channels) channels.push_back({{"name", c.name}, {"unit", c.unit}});
    identify_ = {{"step", "identify"},
                 {"kind", subject.request.kind},
                 {"options", subject.request.options},
                 {"device", subject.device},
                 {"driver", subject.driver},
                 {"channels", std::move(channels)},
                 {"instrument", formats::instrument_metadata(subject.request.instrument)},
                 {"derived", subject.derived}};
    if (subject.explain_memory_mb) identify_["explain_memory_mb"] = *subject.explain_memory_mb;
  }

  ~InProcess() override {
    if (to_child_ >= 0) close(to_child_);  // the end of its input: it exits
    if (from_child_ >= 0) close(from_child_);
    if (pid_ <= 0) return;
    // A child still at a step is waited for (as the daemon waits for its own identification); one that
    // does not end within 10 s of its last answer is killed.
    for (int i = 0; i < 1000 && asked_ == answered_; ++i) {
      if (waitpid(pid_, nullptr, WNOHANG) == pid_) return;
      usleep(10'000);
    }
    if (asked_ == answered_) kill(pid_, SIGKILL);
    while (waitpid(pid_, nullptr, 0) < 0 && errno == EINTR) {
    }
  }

  results::Params identify() override {
    const nlohmann::json answer = ask(identify_, "params");
    try {
      return results::params_from_json(answer.at("params"));
    } catch (const std::exception& e) {
      throw std::runtime_error(who() + " answered PARAMS that do not read: " + e.what());
    }
  }

  std::optional<results::Explanation> explain() override {
    const nlohmann::json answer = ask({{"step", "explain"}}, "explanation");
    if (answer.at("explanation").is_null()) return std::nullopt;
    try {
      return results::explanation_from_json(answer.at("explanation"));
    } catch (const std::exception& e) {
      throw std::runtime_error(who() + " answered an EXPLAIN that does not read: " + e.what());
    }
  }

  void write_report(const SessionReportRequest& request, const std::string& path) override {
    (void)ask({{"step", "report"},
               {"inputs", request.inputs},
               {"title", request.title},
               {"subtitle", request.subtitle},
               {"device", request.device},
               {"instrument", formats::instrument_metadata(request.instrument)},
               {"checked_on", to_iso(request.checked_on)},
               {"path", path}},
              "written");
  }

 private:
  [[nodiscard]] std::string who() const {
    return "the session's analysis process (" + executable_ + " --analyse-session, pid " + std::to_string(pid_) + ")";
  }

  // Sends one request and reads its answer line; throws std::runtime_error with the child's error, or saying
  // how the child failed (gone: how it ended; an answer that is not JSON, or lacks `key`).
  nlohmann::json ask(const nlohmann::json& request, const char* key) {
    if (gone_) throw std::runtime_error(who() + " had ended (" + how_ + ")");
    const std::string line = request.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
    ++asked_;
    for (std::size_t done = 0; done < line.size();) {
      const ssize_t n = ::send(to_child_, line.data() + done, line.size() - done, MSG_NOSIGNAL);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) fail_ended();  // EPIPE: it is gone
      done += static_cast<std::size_t>(n);
    }
    std::string answer;
    for (;;) {
      if (const auto nl = buffer_.find('\n'); nl != std::string::npos) {
        answer = buffer_.substr(0, nl);
        buffer_.erase(0, nl + 1);
        break;
      }
      char chunk[65536];
      const ssize_t n = ::read(from_child_, chunk, sizeof chunk);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) fail_ended();
      buffer_.append(chunk, static_cast<std::size_t>(n));
    }
    ++answered_;
    nlohmann::json j = nlohmann::json::parse(answer, nullptr, false);
    if (j.is_discarded() || !j.is_object()) {
      throw std::runtime_error(who() + " answered what is not a JSON object: \"" + answer.substr(0, 200) + "\"");
    }
    if (const auto it = j.find("error"); it != j.end() && it->is_string()) throw std::runtime_error(it->get<std::string>());
    if (!j.contains(key)) throw std::runtime_error(who() + " answered without \"" + key + "\": " + answer.substr(0, 200));
    return j;
  }

  // The child closed its output or its input: killed if it has not ended yet (a child that no longer talks is
  // of no use), reaped, and every later step fails at once.
  [[noreturn]] void fail_ended() {
    gone_ = true;
    close(to_child_);
    to_child_ = -1;
    kill(pid_, SIGKILL);  // no effect on one that exited: its status is kept
    int status = 0;
    pid_t r = 0;
    while ((r = waitpid(pid_, &status, 0)) < 0 && errno == EINTR) {
    }
    how_ = r == pid_ ? how_it_ended(status) : "not reaped: " + std::string(std::strerror(errno));
    const std::string message = who() + " ended without an answer (" + how_ + "; what it said is in the daemon's log)";
    pid_ = -1;
    throw std::runtime_error(message);
  }

  std::string executable_;
  pid_t pid_ = -1;
  int to_child_ = -1;
  int from_child_ = -1;
  std::string buffer_;
  nlohmann::json identify_;
  bool gone_ = false;
  std::string how_;
  int asked_ = 0, answered_ = 0;
};

std::string text_field(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_string()) throw std::runtime_error(std::string("the request has no text \"") + key + "\"");
  return it->get<std::string>();
}

std::vector<std::string> texts_field(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_array()) throw std::runtime_error(std::string("the request has no array \"") + key + "\"");
  std::vector<std::string> out;
  for (const auto& v : *it) {
    if (!v.is_string()) throw std::runtime_error(std::string("\"") + key + "\" holds a non-text");
    out.push_back(v.get<std::string>());
  }
  return out;
}

Instrument instrument_field(const nlohmann::json& j) {
  std::map<std::string, std::string> m;
  if (const auto it = j.find("instrument"); it != j.end() && it->is_object())
    for (const auto& [k, v] : it->items())
      if (v.is_string()) m[k] = v.get<std::string>();
  return formats::instrument_from_metadata(m, "the request's instrument");
}

// The child's session, made by the first request.
struct Analysed {
  std::unique_ptr<sessions::RecordedDevice> device;
  std::unique_ptr<sessions::Session> session;
};

nlohmann::json answer_identify(const nlohmann::json& req, const sessions::SessionRegistry& registry, Analysed& a) {
  const std::string kind_name = text_field(req, "kind");
  const sessions::SessionKind* kind = registry.find(kind_name);
  if (kind == nullptr) throw std::runtime_error("session kind \"" + kind_name + "\" is unknown to this build");
  std::vector<drivers::ChannelInfo> channels;
  if (const auto it = req.find("channels"); it != req.end() && it->is_array())
    for (const auto& c : *it) channels.push_back({text_field(c, "name"), text_field(c, "unit")});
  a.device = std::make_unique<sessions::RecordedDevice>(text_field(req, "device"), text_field(req, "driver"), channels);
  sessions::SessionRequest request{kind_name, a.device->name(), req.value("options", nlohmann::json::object()),
                                   instrument_field(req)};
  try {
    a.session = kind->create(request, *a.device);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(std::string("the session's options are refused: ") + e.what());
  }
  if (const auto it = req.find("explain_memory_mb"); it != req.end() && it->is_number_unsigned())
    a.session->set_explain_memory_mb(it->get<std::size_t>());
  a.session->read_derived(texts_field(req, "derived"));
  return {{"params", results::to_json(a.session->identify())}};
}

nlohmann::json answer(const nlohmann::json& req, const sessions::SessionRegistry& registry,
                      const SessionReportRenderer& renderer, Analysed& a) {
  const std::string step = text_field(req, "step");
  if (step == "identify") return answer_identify(req, registry, a);
  if (!a.session) throw std::runtime_error("\"" + step + "\" before the session was identified");
  if (step == "explain") {
    const auto e = a.session->explain();
    return {{"explanation", e ? results::to_json(*e) : nlohmann::json(nullptr)}};
  }
  if (step == "report") {
    const auto checked_on = parse_iso_date(text_field(req, "checked_on"));
    if (!checked_on) throw std::runtime_error("\"checked_on\" is no date YYYY-MM-DD");
    const std::string path = text_field(req, "path");
    InDaemon here(*a.session, renderer);
    here.write_report({.inputs = texts_field(req, "inputs"),
                       .title = text_field(req, "title"),
                       .subtitle = text_field(req, "subtitle"),
                       .device = text_field(req, "device"),
                       .instrument = instrument_field(req),
                       .checked_on = *checked_on,
                       .session = a.session.get()},
                      path);
    return {{"written", path}};
  }
  throw std::runtime_error("unknown step \"" + step + "\" (identify, explain, report)");
}

}  // namespace

std::unique_ptr<SessionAnalysis> analysis_in_daemon(sessions::Session& session, SessionReportRenderer renderer) {
  return std::make_unique<InDaemon>(session, std::move(renderer));
}

std::unique_ptr<SessionAnalysis> analysis_in_process(const std::string& executable, const AnalysisSubject& subject) {
  return std::make_unique<InProcess>(executable, subject);
}

int run_session_analysis(std::istream& in, std::ostream& out, const sessions::SessionRegistry& registry,
                         const SessionReportRenderer& renderer) {
  Analysed analysed;
  bool any = false;
  for (std::string line; std::getline(in, line);) {
    const nlohmann::json req = nlohmann::json::parse(line, nullptr, false);
    nlohmann::json reply;
    if (req.is_discarded() || !req.is_object()) {
      reply = {{"error", "the session's analysis process was sent what is not a JSON object"}};
    } else {
      try {
        reply = answer(req, registry, renderer, analysed);
      } catch (const std::exception& e) {
        reply = {{"error", e.what()}};
      }
    }
    any = true;
    out << reply.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) << "\n" << std::flush;
  }
  return any ? 0 : 2;
}

}  // namespace guideway::daemon
