#pragma once
// Runs test sessions: a PipelineStage that feeds each running session (and its raw recorder) with its
// device's samples, and a worker thread that finishes sessions (closes the recording, identifies,
// publishes PARAMS or a session_failed EVENT) so identification never stalls the pipeline.
// Thread safety: start/stop/snapshot from the event-loop thread; on_samples/on_tick from the pipeline.

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/instrument.hpp"
#include "daemon/outbox.hpp"
#include "daemon/pipeline.hpp"
#include "results/result_header.hpp"
#include "sessions/recorder.hpp"
#include "sessions/session.hpp"

namespace guideway::daemon {

class SessionAnalysis;  // session_analysis.hpp

// A session's life: running until stopped or its end condition, finishing while its files are written,
// then done or failed (with the reason in `progress`).
enum class SessionState { running, finishing, done, failed };
[[nodiscard]] std::string_view to_string(SessionState state) noexcept;

struct SessionInfo {
  std::string name;
  std::string kind;
  std::string device;
  SessionState state = SessionState::running;
  std::string progress;
  std::string recording;  // path of the raw recording ("" if not recorded)
  std::string recording_error;
  std::uint64_t samples = 0;
  std::vector<std::string> warnings;  // at its start: its instrument's calibration had run out
  std::optional<double> time_left_s;  // Session::time_left_s() while it runs
};

// Where a finished session's HTML report is kept (the `report` request serves it).
std::string report_path(const std::string& state_dir, const std::string& session);

// What a finished session's report is made from: its files, its heading, its device's instrument, and the
// session itself for what it identified (Session::identified_planes: the files are not identified again).
struct SessionReportRequest {
  std::vector<std::string> inputs;
  std::string title;
  std::string subtitle;
  std::string device;
  Instrument instrument;   // empty: none stated
  CalendarDate checked_on;  // UTC: the date its instrument's calibration is judged on
  const sessions::Session* session = nullptr;
};
// Renders the HTML page of a session's report; throws with the reason. guidewayd gives report/'s
// (daemon/reports/session_report.hpp): the daemon itself does not link the report and the models it draws
// with, so that what tests the daemon's threads (the TSan build) compiles none of them.
using SessionReportRenderer = std::function<std::string(const SessionReportRequest&)>;

class SessionManager : public PipelineStage {
 public:
  SessionManager(const sessions::SessionRegistry& registry, std::vector<drivers::Driver*> devices, std::string state_dir,
                 Outbox& outbox);
  ~SessionManager() override;

  // The instrument of each device (in the order of the devices) and whether a session on one whose
  // calibration has run out, or states no due date, is refused. Before the first start().
  void set_instruments(std::vector<Instrument> instruments, bool refuse_uncalibrated);
  // What every session's EXPLAIN may keep in its caches (the configuration's [explain] memory_mb); unset:
  // EXPLAIN's default. Before the first start.
  void set_explain_memory_mb(std::size_t mb) { explain_memory_mb_ = mb; }
  // How sessions' reports are rendered (none: every session ends with report_failed saying so). Before the
  // first start.
  void set_report_renderer(SessionReportRenderer renderer) { report_renderer_ = std::move(renderer); }
  // The program whose `--analyse-session` identifies, explains and reports a session identified from its
  // derived files (Session::identifies_from_derived) in a process of its own (session_analysis.hpp): guidewayd
  // gives itself. "" (the default): every session is analysed in the daemon. Before the first start.
  void set_analysis_executable(std::string executable) { analysis_executable_ = std::move(executable); }
  // Creates and queues a session; returns its name. Throws std::invalid_argument with the reason.
  // The request's instrument is the device's (set_instruments).
  std::string start(const sessions::SessionRequest& request);
  // Requests the end of a session (or of all when name is empty); returns the names affected.
  std::vector<std::string> stop(const std::string& name);
  [[nodiscard]] std::vector<SessionInfo> snapshot() const;
  [[nodiscard]] bool known_kind(const std::string& kind) const { return registry_.find(kind) != nullptr; }
  [[nodiscard]] std::string kinds() const;  // "dbb, straightness, ..."

  // A session begun when a device's channel rises above 0.5 and ended when it falls: a controller's pin
  // ([[session_trigger]]; LinuxCNC's session pin, docs/linuxcnc.md). Set before the pipeline runs.
  struct Trigger {
    std::size_t device_index = 0;
    std::size_t channel = 0;
    std::string pin;  // "linuxcnc.session", for the events
    sessions::SessionRequest request;
    double end_after_s = 0.0;  // the session ends this long after the channel falls
  };
  void set_triggers(std::vector<Trigger> triggers);

  // Raw samples go to the recordings and to the sessions: identification, uncertainties and EXPLAIN
  // come from what was measured ([[processing]] is for the live display, SAMPLE's `denoised`).
  void on_samples(std::size_t device_index, const drivers::Driver& device, std::span<const Sample> samples) override;
  void on_tick(std::int64_t now_mono_ns) override;

 private:
  struct Running {
    SessionInfo info;
    std::size_t device_index = 0;
    std::unique_ptr<sessions::Session> session;
    std::unique_ptr<sessions::RawRecorder> recorder;
    bool stop_requested = false;
    std::uint64_t recorder_errors_seen = 0;  // recorder->error_count() when last looked at
    std::string reported_error;              // the last recording_failed reason posted
    Instrument instrument;                   // its device's
    CalendarDate started_on;                 // UTC: the date its instrument's calibration is judged on
    nlohmann::json options;                  // of its request, for an analysis process to create it again
  };
  [[nodiscard]] results::ResultHeader header_of(const Running& r) const;
  [[nodiscard]] bool still_running(const std::string& name) const;  // not yet finishing or done
  // Throws std::invalid_argument when refuse_uncalibrated refuses a session on this device.
  void check_calibration(std::size_t device_index, const CalendarDate& today) const;
  void finish_loop(const std::stop_token& stop);
  void finish(std::unique_ptr<Running> r);
  // Posts EXPLAIN (or an explain_failed EVENT); returns the file the explanation was saved to.
  std::optional<std::string> post_explanation(Running& r, SessionAnalysis& analysis);
  // Renders NAME.report.html from the session's files; a failure is an EVENT.
  void write_session_report(const Running& r, std::vector<std::string> inputs, SessionAnalysis& analysis);
  // The session's derived files (Session::write_derived), made 0640; a disk error is left in `error`.
  std::vector<std::string> write_derived(Running& r, std::string& error);
  void post_event(const SessionInfo& info, const std::string& event, const std::string& reason);
  // A trigger's channel crossed 0.5 (pipeline thread): its session starts, or is asked to end.
  void triggered(std::size_t index, bool on);
  // Ends the triggered sessions whose channel fell end_after_s ago (pipeline thread).
  void end_triggered(std::int64_t now_ns);
  // A disk error of the session's files: kept for STATUS and PARAMS (`recording_error`), and an
  // EVENT recording_failed (logged by the daemon) unless this very reason was posted already.
  void report_recording_error(Running& r, const std::string& reason);

  const sessions::SessionRegistry& registry_;
  std::vector<drivers::Driver*> devices_;
  std::vector<Instrument> instruments_;  // per device (empty: none stated)
  bool refuse_uncalibrated_ = false;
  std::optional<std::size_t> explain_memory_mb_;
  SessionReportRenderer report_renderer_;
  std::string analysis_executable_;
  std::string state_dir_;
  Outbox& outbox_;

  mutable std::mutex mutex_;  // guards incoming_, stops_, infos_
  std::vector<std::unique_ptr<Running>> incoming_;
  std::vector<std::string> stops_;
  std::vector<SessionInfo> infos_;  // every session this run, newest last

  std::vector<std::unique_ptr<Running>> running_;  // pipeline thread only
  struct TriggerState {
    Trigger trigger;
    bool on = false;
    std::string session;            // the one it started ("": none)
    std::int64_t end_at_ns = 0;     // when the channel fell: the session ends then (0: not falling)
  };
  std::vector<TriggerState> triggers_;  // pipeline thread only (after set_triggers)

  std::mutex finish_mutex_;
  std::condition_variable_any finish_cv_;
  std::deque<std::unique_ptr<Running>> finishing_;
  std::jthread worker_;
};

}  // namespace guideway::daemon
