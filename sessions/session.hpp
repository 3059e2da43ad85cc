#pragma once
// Test sessions: a DBB circle set, a straightness traverse, a run-out revolution, a profile. A
// session is created from a start request on the event-loop thread (so bad options are answered at
// once), then fed on the pipeline thread with its device's samples, and identified on a worker
// thread when it completes or is stopped.

#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/instrument.hpp"
#include "core/sample.hpp"
#include "drivers/driver.hpp"
#include "results/explanation.hpp"
#include "results/params.hpp"

// A DBB session's identification as PARAMS published it (models/explain/dbb_checked.hpp): named here only, so
// that what runs sessions (the daemon) needs none of the models it does not call.
namespace guideway::models::explain {
struct CheckedIdentification;
}  // namespace guideway::models::explain

namespace guideway::sessions {

// Most samples a session is given in one on_samples() call: the daemon's pipeline takes this many from
// a ring at once, and a replay feeds a recording in the same pieces, so both run the same calls.
inline constexpr std::size_t max_feed_batch = 512;

struct SessionRequest {
  std::string kind;    // "dbb", "straightness", "runout", "profile", ...
  std::string device;  // device name; empty = the first device the kind accepts
  nlohmann::json options = nlohmann::json::object();
  // The device's instrument (the daemon's configuration, or a recording's header): a DBB session's
  // uncertainties include its bar's calibrated length.
  Instrument instrument{};
};

// One running test. on_samples() and complete() are called on the pipeline thread; identify() on
// the worker thread after the last on_samples(). Not otherwise thread safe.
class Session {
 public:
  virtual ~Session() = default;
  // What explain() runs EXPLAIN with beyond its defaults: the daemon's [explain] memory_mb (set after create(),
  // before explain(); docs/configuration.md). Unset: EXPLAIN's default (sessions/explain_options.hpp).
  void set_explain_memory_mb(std::size_t mb) { explain_memory_mb_ = mb; }
  [[nodiscard]] std::optional<std::size_t> explain_memory_mb() const { return explain_memory_mb_; }
  virtual void on_samples(std::span<const Sample> samples) = 0;
  // Another device's samples, as they come (pipeline thread): a controller's commanded positions (a
  // linuxcnc-hal device's x_cmd, y_cmd, z_cmd) a DBB session writes beside the bar's reading. Default: none.
  virtual void on_other_samples(const drivers::Driver& device, std::span<const Sample> samples) {
    (void)device;
    (void)samples;
  }
  // True once the session has all it needs (e.g. every pattern of a DBB test): it then finishes
  // without a stop request.
  [[nodiscard]] virtual bool complete() const { return false; }
  // Human-readable progress for STATUS, e.g. "pattern 2/3, 210 of 360 deg".
  [[nodiscard]] virtual std::string progress() const { return {}; }
  // Seconds until the session has all it needs, estimated from its programme (a DBB test's circles at
  // its feed, a run-out's revolutions at its speed, a traverse's stations at the pace measured so far);
  // nullopt while it cannot say (waiting for an operator, a traverse of open length).
  [[nodiscard]] virtual std::optional<double> time_left_s() const { return std::nullopt; }
  // Identified parameters: the body of the PARAMS message (results/params.hpp: its model, its figures with
  // their uncertainties by catalogue group, the model's record of the fit). Throws std::runtime_error with
  // the reason when identification is impossible.
  virtual results::Params identify() = 0;
  // After a successful identify(), on the worker thread: where the recording and the identified model
  // still differ and which left-out physics explains it (models/explain; the body of the EXPLAIN
  // message, results/explanation.hpp), or nullopt for a kind without an explanation model. Throws
  // std::runtime_error.
  virtual std::optional<results::Explanation> explain() { return std::nullopt; }
  // After identify(), on the worker thread: the identification per plane as PARAMS published it (a DBB
  // session: Lai's model and the diagnostics with EXPLAIN's findings fitted beside), for whoever builds the
  // session's report, so it does not identify the run files a second time. Default: none; the report reads
  // the files (nullptr). Valid while the session lives.
  [[nodiscard]] virtual const std::vector<models::explain::CheckedIdentification>* identified_planes() const {
    return nullptr;
  }
  // Metadata for the recording header (options, geometry), written as "# key = value".
  [[nodiscard]] virtual std::map<std::string, std::string> metadata() const { return {}; }
  // Derived files (e.g. DBB run files) written next to the raw recording at the end; returns paths.
  virtual std::vector<std::string> write_derived(const std::string& dir, const std::string& base_name) {
    (void)dir;
    (void)base_name;
    return {};
  }
  // True when identify(), explain() and identified_planes() need nothing but what write_derived() wrote: a
  // session created with the same request that read_derived() them gives the same results. The daemon then
  // runs them in a process of its own (daemon/session_analysis.hpp), whose peak memory is not the daemon's.
  [[nodiscard]] virtual bool identifies_from_derived() const { return false; }
  // Reads back what write_derived() wrote (after create(), instead of samples). Throws std::runtime_error
  // naming the file.
  virtual void read_derived(const std::vector<std::string>& paths) {
    (void)paths;
    throw std::runtime_error("this session kind is not identified from its derived files");
  }
 private:
  std::optional<std::size_t> explain_memory_mb_;
};

struct SessionKind {
  std::string kind;
  std::string description;
  std::vector<std::string> drivers;  // drivers whose devices this kind accepts
  // Throws std::invalid_argument naming the bad option.
  std::function<std::unique_ptr<Session>(const SessionRequest&, const drivers::Driver& device)> create;
  // The options a recording's session ran with, from its recorded options and header (a recording made
  // before an option existed ran with that option's default of its day); none: the recorded options.
  std::function<nlohmann::json(nlohmann::json options, const std::map<std::string, std::string>& header)>
      recorded_options;
};

class SessionRegistry {
 public:
  void add(SessionKind kind);
  [[nodiscard]] const SessionKind* find(std::string_view kind) const;
  [[nodiscard]] std::vector<std::string> kinds() const;

 private:
  std::vector<SessionKind> kinds_;
};

}  // namespace guideway::sessions
