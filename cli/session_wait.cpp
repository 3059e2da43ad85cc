// Waiting for a session the CLI started (session_wait.hpp): its progress, then its PARAMS.
#include "cli/session_wait.hpp"

#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>

#include "cli/params_print.hpp"
#include "cli/progress.hpp"
#include "results/message_class.hpp"
#include "results/session_kinds.hpp"

namespace guideway::cli {

namespace {

// While `start --wait` waits: the session's state, progress and time left (its estimate from its programme)
// from the daemon's STATUS ("" when STATUS does not name it).
std::string session_doing(const nlohmann::json& status, const std::string& session) {
  for (const auto& s : status.value("sessions", nlohmann::json::array())) {
    if (!s.is_object() || s.value("session", "") != session) continue;
    const std::string progress = s.value("progress", "");
    std::string doing = s.value("state", "?") + (progress.empty() ? "" : ": " + progress);
    // A DBB test's estimate is its circles' tracing only: the machine's moves between them (its own
    // programme) come on top, so it is a lower bound (the demo: 75 s said, 134 s taken).
    const std::string seconds = s.contains("time_left_s")
                                    ? std::to_string(std::lround(s.value("time_left_s", 0.0))) + " s left"
                                    : std::string();
    if (!seconds.empty())
      doing += s.value("kind", "") == results::dbb_kind.name ? ", at least " + seconds + " (circles to trace)"
                                                              : ", about " + seconds;
    return doing;
  }
  return {};
}

// After `start --wait`: the session's PARAMS (printed), or its failure, within the timeout.
}  // namespace

void watch_session_progress(DaemonClient& c) {
  const nlohmann::json classes = {results::to_string(results::MessageClass::params),
                                  results::to_string(results::MessageClass::event),
                                  results::to_string(results::MessageClass::status)};
  c.request(results::request(results::RequestClass::watch, {{"classes", classes}}), results::MessageClass::watch);
}

nlohmann::json wait_for_params(DaemonClient& c, const std::string& session, double timeout_s, bool quiet, bool json,
                               bool print) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  Progress progress("", json || quiet, 0.0);  // from the start: the session's phases
  while (std::chrono::steady_clock::now() < deadline) {
    auto line = c.read_line(std::chrono::milliseconds(500));
    if (!line) continue;
    const auto m = nlohmann::json::parse(*line, nullptr, false);
    if (m.is_discarded()) continue;
    if (results::has_class(m, results::MessageClass::status)) {
      if (std::string doing = session_doing(m, session); !doing.empty()) progress.doing(std::move(doing));
      continue;
    }
    if (m.value("session", "") != session) continue;
    if (results::has_class(m, results::MessageClass::event) && m.value("event", "") == "session_failed") {
      progress.doing("");  // the session's end: no progress line among what follows
      if (json && print) std::cout << m.dump() << "\n";
      throw std::runtime_error("session " + session + " failed: " + m.value("reason", "?"));
    }
    if (results::has_class(m, results::MessageClass::params)) {
      progress.doing("");
      if (print && json) {
        std::cout << m.dump() << "\n";
      } else if (print) {
        print_params(m);
      }
      return m;
    }
  }
  std::ostringstream why;
  why << "no parameters for session " << session << " within " << timeout_s << " s (it goes on: guideway stop "
      << session << " ends it)";
  throw std::runtime_error(why.str());
}

}  // namespace guideway::cli
