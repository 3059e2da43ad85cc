#pragma once
// A finished session's analysis: its identification (for a DBB session, checked by EXPLAIN), its EXPLAIN and
// the HTML report drawn from them. SessionManager's worker thread runs it either in the daemon or, for a kind
// identified from its derived files (Session::identifies_from_derived: the DBB session's run files), in a
// process of its own: `guidewayd --analyse-session`, started with posix_spawn, which creates the session from
// the same request, reads the files back and answers each step as one JSON line. Its working set (tens of MB
// for 2 x 18k samples, bench/README.md) is then the child's: the daemon's RSS stays at rest, and glibc's kept
// free memory (core/memory_policy.hpp: the child keeps it, the daemon does not) goes with the child. A child
// that crashes, exits or answers what is not JSON fails the step it was asked with a reason naming it; the
// daemon goes on.
//
// Protocol (stdin/stdout of the child, one JSON object per line each way, in this order):
//   {"step":"identify", "kind", "options", "device", "driver", "channels":[{"name","unit"}],
//    "instrument":{instrument_* keys}, "explain_memory_mb"?, "derived":[paths]}  -> {"params":PARAMS body}
//   {"step":"explain"}                                                          -> {"explanation":body|null}
//   {"step":"report", "inputs", "title", "subtitle", "device", "instrument", "checked_on":"YYYY-MM-DD",
//    "path"}                                                                    -> {"written":path}
// Any step may be answered {"error":"reason"} (the reason the step would have thrown in the daemon). The child
// ends at the end of its input.

#include <sys/types.h>

#include <istream>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "daemon/session_manager.hpp"
#include "results/explanation.hpp"
#include "results/params.hpp"
#include "sessions/session.hpp"

namespace guideway::daemon {

class SessionAnalysis {
 public:
  virtual ~SessionAnalysis() = default;
  // Session::identify(): throws std::runtime_error with the reason the session failed.
  virtual results::Params identify() = 0;
  // Session::explain() after identify(): throws std::runtime_error (an explain_failed EVENT).
  virtual std::optional<results::Explanation> explain() = 0;
  // Renders the session's report and writes it (atomically, sessions::recording_file_mode) to `path`. Throws
  // std::runtime_error (a report_failed EVENT). `request.session` is ignored: the analysed session's.
  virtual void write_report(const SessionReportRequest& request, const std::string& path) = 0;
};

// In the daemon: the session itself, its report by `renderer` (none: every report fails saying so).
std::unique_ptr<SessionAnalysis> analysis_in_daemon(sessions::Session& session, SessionReportRenderer renderer);

// What the analysis process creates the session from: its request, its device as the session saw it, and
// the files it wrote (Session::write_derived).
struct AnalysisSubject {
  sessions::SessionRequest request;  // kind, options, instrument
  std::string device;
  std::string driver;
  std::vector<drivers::ChannelInfo> channels;
  std::optional<std::size_t> explain_memory_mb;
  std::vector<std::string> derived;
};

// Starts `executable --analyse-session` (posix_spawn: no fork of the multithreaded daemon) and asks it to
// identify `subject`'s session. Throws std::runtime_error when it cannot be started. Its destructor ends its
// input and reaps it (a child still working is waited for, as an identification in the daemon would be).
std::unique_ptr<SessionAnalysis> analysis_in_process(const std::string& executable, const AnalysisSubject& subject);

// `guidewayd --analyse-session`: answers the requests read from `in` on `out` until `in` ends, with the
// session kinds of `registry` and reports by `renderer`. Returns the exit status (0; 2 for input that is no
// request at all).
int run_session_analysis(std::istream& in, std::ostream& out, const sessions::SessionRegistry& registry,
                         const SessionReportRenderer& renderer);

}  // namespace guideway::daemon
