// Runs test sessions (session_manager.hpp): feeds, records, identifies and explains them, and builds their reports.
#include "daemon/session_manager.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <cstdio>
#include <ctime>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/atomic_file.hpp"
#include "core/mono_clock.hpp"
#include "core/utc_time.hpp"
#include "daemon/session_analysis.hpp"
#include "formats/raw_recording.hpp"
#include "results/explanation.hpp"
#include "results/params.hpp"
#include "results/result_header.hpp"

namespace guideway::daemon {

std::string_view to_string(SessionState state) noexcept {
  switch (state) {
    case SessionState::running: return "running";
    case SessionState::finishing: return "finishing";
    case SessionState::done: return "done";
    case SessionState::failed: return "failed";
  }
  return "unknown";
}

namespace {

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : ", ") + s;
  return out;
}

}  // namespace

// The header of the session's results: which session, of which kind, on which device, by which instrument.
results::ResultHeader SessionManager::header_of(const Running& r) const {
  results::ResultHeader h;
  h.session = r.info.name;
  h.kind = r.info.kind;
  h.device = r.info.device;
  h.instrument = r.instrument;
  h.instrument_checked_on = r.started_on;
  return h;
}

void SessionManager::set_instruments(std::vector<Instrument> instruments, bool refuse_uncalibrated) {
  instruments_ = std::move(instruments);
  instruments_.resize(devices_.size());
  refuse_uncalibrated_ = refuse_uncalibrated;
}

void SessionManager::check_calibration(std::size_t index, const CalendarDate& today) const {
  if (!refuse_uncalibrated_) return;
  const Instrument& in = instruments_[index];
  const std::string& device = devices_[index]->name();
  const std::string why = "refused: [daemon] refuse_uncalibrated = true";
  if (!in.calibration_due) {
    const std::string who = instrument_identity_text(in);
    throw std::invalid_argument("device " + device + (who.empty() ? "" : " (" + who + ")") +
                                ": no calibration_due is configured, so its calibration cannot be shown valid; " + why +
                                " (state the certificate's calibrated_on and calibration_due in its [[device]] table)");
  }
  if (const std::string w = calibration_warning(device, in, today); !w.empty())
    throw std::invalid_argument(w + "; " + why);
}

SessionManager::SessionManager(const sessions::SessionRegistry& registry, std::vector<drivers::Driver*> devices,
                               std::string state_dir, Outbox& outbox)
    : registry_(registry),
      devices_(std::move(devices)),
      state_dir_(std::move(state_dir)),
      outbox_(outbox) {
  worker_ = std::jthread([this](std::stop_token stop) { finish_loop(stop); });
}

SessionManager::~SessionManager() {
  worker_.request_stop();
  finish_cv_.notify_all();
  worker_.join();
}

std::string SessionManager::start(const sessions::SessionRequest& request) {
  const sessions::SessionKind* kind = registry_.find(request.kind);
  if (!kind) {
    throw std::invalid_argument("unknown session kind \"" + request.kind + "\" (known: " + join(registry_.kinds()) + ")");
  }
  std::size_t index = devices_.size();
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    const bool accepted = std::find(kind->drivers.begin(), kind->drivers.end(), devices_[i]->driver()) != kind->drivers.end();
    if (request.device.empty() ? accepted : devices_[i]->name() == request.device) {
      if (!accepted) {
        throw std::invalid_argument("device \"" + request.device + "\" (driver " + devices_[i]->driver() +
                                    ") cannot run a " + request.kind + " session (needs: " + join(kind->drivers) + ")");
      }
      index = i;
      break;
    }
  }
  if (index == devices_.size()) {
    throw std::invalid_argument(request.device.empty()
                                    ? "no configured device can run a " + request.kind + " session (needs a driver among: " +
                                          join(kind->drivers) + ")"
                                    : "no device named \"" + request.device + "\"");
  }
  auto r = std::make_unique<Running>();
  r->device_index = index;
  r->instrument = index < instruments_.size() ? instruments_[index] : Instrument{};
  r->started_on = utc_today();
  check_calibration(index, r->started_on);
  sessions::SessionRequest with_instrument = request;
  with_instrument.instrument = r->instrument;
  r->session = kind->create(with_instrument, *devices_[index]);  // throws std::invalid_argument on bad options
  r->options = request.options;
  if (explain_memory_mb_) r->session->set_explain_memory_mb(*explain_memory_mb_);
  {
    std::lock_guard lock(mutex_);
    // A session holds its device while it records; one that is identifying (finishing) has its samples
    // and leaves the device to the next (a program running two tests back to back: the second begins
    // while the first is identified; the finish thread takes them in turn).
    for (const auto& info : infos_) {
      if (info.device == devices_[index]->name() && info.state == SessionState::running) {
        throw std::invalid_argument("device \"" + info.device + "\" is busy with session " + info.name);
      }
    }
    std::string name = request.kind + "-" + devices_[index]->name() + "-" + utc_now("%Y%m%dT%H%M%SZ");
    int suffix = 1;
    const std::string base = name;
    while (std::any_of(infos_.begin(), infos_.end(), [&](const SessionInfo& i) { return i.name == name; })) {
      name = base + "-" + std::to_string(++suffix);
    }
    r->info = {name, request.kind, devices_[index]->name(), SessionState::running, "", "", "", 0, {}, {}};
    if (std::string w = calibration_warning(r->info.device, r->instrument, r->started_on); !w.empty())
      r->info.warnings.push_back(std::move(w));
    auto meta = r->session->metadata();
    meta.merge(formats::instrument_metadata(r->instrument));
    meta["session"] = name;
    meta["kind"] = request.kind;
    meta["options"] = request.options.dump();
    try {
      r->recorder = std::make_unique<sessions::RawRecorder>(state_dir_, name, *devices_[index], meta);
      r->info.recording = r->recorder->part_path();
    } catch (const std::exception& e) {
      r->info.recording_error = e.what();  // acquisition and identification go on without a recording
      post_event(r->info, "recording_failed", e.what());
    }
    infos_.push_back(r->info);
    incoming_.push_back(std::move(r));
    return name;
  }
}

std::string SessionManager::kinds() const { return join(registry_.kinds()); }

std::vector<std::string> SessionManager::stop(const std::string& name) {
  std::lock_guard lock(mutex_);
  std::vector<std::string> out;
  for (auto& info : infos_) {
    if (info.state == SessionState::running && (name.empty() || info.name == name)) {
      stops_.push_back(info.name);
      out.push_back(info.name);
    }
  }
  if (out.empty()) {
    throw std::invalid_argument(name.empty() ? "no session is running" : "no running session named \"" + name + "\"");
  }
  return out;
}

std::vector<SessionInfo> SessionManager::snapshot() const {
  std::lock_guard lock(mutex_);
  return infos_;
}

void SessionManager::set_triggers(std::vector<Trigger> triggers) {
  for (auto& t : triggers) triggers_.push_back({std::move(t), false, {}});
}

bool SessionManager::still_running(const std::string& name) const {
  std::lock_guard lock(mutex_);
  return std::any_of(infos_.begin(), infos_.end(),
                     [&](const SessionInfo& i) { return i.name == name && i.state == SessionState::running; });
}

void SessionManager::triggered(std::size_t index, bool on) {
  TriggerState& t = triggers_[index];
  t.on = on;
  SessionInfo about;
  about.device = devices_[t.trigger.device_index]->name();
  if (on) {
    if (!t.session.empty() && still_running(t.session)) {  // up again before its session ended: it goes on
      t.end_at_ns = 0;
      return;
    }
    // Its last session ended by itself (every pattern traced) while the trigger waited end_after_s: a new one.
    t.session.clear();
    t.end_at_ns = 0;
    try {
      t.session = start(t.trigger.request);
      about.name = t.session;
      post_event(about, "session_triggered", t.trigger.pin + " rose: session " + t.session + " begins");
    } catch (const std::invalid_argument& e) {
      t.session.clear();
      post_event(about, "session_trigger_failed", t.trigger.pin + " rose but no session began: " + e.what());
    }
    return;
  }
  if (t.session.empty()) return;
  t.end_at_ns = mono_now_ns() + static_cast<std::int64_t>(t.trigger.end_after_s * 1e9);
}

void SessionManager::end_triggered(std::int64_t now_ns) {
  for (TriggerState& t : triggers_) {
    if (t.end_at_ns == 0 || now_ns < t.end_at_ns || t.session.empty()) continue;
    SessionInfo about;
    about.device = devices_[t.trigger.device_index]->name();
    about.name = t.session;
    try {
      stop(t.session);
      post_event(about, "session_triggered",
                 t.trigger.pin + " fell: session " + t.session + " ends (" + std::to_string(t.trigger.end_after_s) +
                     " s after it, for the instrument's last readings)");
    } catch (const std::invalid_argument&) {
      // It had ended already (every pattern traced).
    }
    t.session.clear();
    t.end_at_ns = 0;
  }
}

void SessionManager::on_samples(std::size_t device_index, const drivers::Driver& device,
                                std::span<const Sample> samples) {
  for (std::size_t i = 0; i < triggers_.size(); ++i) {
    if (triggers_[i].trigger.device_index != device_index) continue;
    const std::size_t ch = triggers_[i].trigger.channel;
    for (const Sample& s : samples) {
      if (ch >= s.value_count) continue;
      const bool on = s.value[ch] > 0.5;
      if (on != triggers_[i].on) triggered(i, on);
    }
  }
  for (auto& r : running_) {
    if (r->device_index != device_index) {
      r->session->on_other_samples(device, samples);
      continue;
    }
    if (r->recorder) r->recorder->push(samples);
    r->info.samples += samples.size();
    r->session->on_samples(samples);
  }
}

void SessionManager::on_tick(std::int64_t now_mono_ns) {
  end_triggered(now_mono_ns);
  std::vector<std::string> stops;
  {
    std::lock_guard lock(mutex_);
    for (auto& r : incoming_) running_.push_back(std::move(r));
    incoming_.clear();
    stops.swap(stops_);
    // Progress for STATUS.
    for (const auto& r : running_) {
      for (auto& info : infos_) {
        if (info.name == r->info.name) {
          info.progress = r->session->progress();
          info.time_left_s = r->session->time_left_s();
          info.samples = r->info.samples;
        }
      }
    }
  }
  // A disk error is reported while the session runs, not only at its end (the writer thread retries
  // every flush period; the same reason is posted once).
  for (auto& r : running_) {
    if (!r->recorder || r->recorder->error_count() == r->recorder_errors_seen) continue;
    r->recorder_errors_seen = r->recorder->error_count();
    if (std::string e = r->recorder->error(); !e.empty()) report_recording_error(*r, e);
  }
  for (auto it = running_.begin(); it != running_.end();) {
    Running& r = **it;
    r.stop_requested = r.stop_requested || std::find(stops.begin(), stops.end(), r.info.name) != stops.end();
    if (r.stop_requested || r.session->complete()) {
      {
        std::lock_guard lock(mutex_);
        for (auto& info : infos_) {
          if (info.name == r.info.name) info.state = SessionState::finishing;
        }
      }
      {
        std::lock_guard lock(finish_mutex_);
        finishing_.push_back(std::move(*it));
      }
      finish_cv_.notify_one();
      it = running_.erase(it);
    } else {
      ++it;
    }
  }
}

void SessionManager::finish_loop(const std::stop_token& stop) {
  for (;;) {
    std::unique_ptr<Running> r;
    {
      std::unique_lock lock(finish_mutex_);
      finish_cv_.wait(lock, stop, [this] { return !finishing_.empty(); });
      if (finishing_.empty()) return;  // stop requested and nothing left
      r = std::move(finishing_.front());
      finishing_.pop_front();
    }
    finish(std::move(r));
  }
}

void SessionManager::report_recording_error(Running& r, const std::string& reason) {
  r.info.recording_error = reason;
  {
    std::lock_guard lock(mutex_);
    for (auto& info : infos_) {
      if (info.name == r.info.name) info.recording_error = reason;
    }
  }
  if (reason == r.reported_error) return;
  r.reported_error = reason;
  post_event(r.info, "recording_failed", reason);
}

void SessionManager::post_event(const SessionInfo& info, const std::string& event, const std::string& reason) {
  outbox_.post(make_message(Event{.event = event, .device = info.device, .session = info.name, .reason = reason}));
}

std::optional<std::string> SessionManager::post_explanation(Running& r, SessionAnalysis& analysis) {
  const SessionInfo& info = r.info;
  try {
    const std::optional<results::Explanation> explained = analysis.explain();
    if (!explained) return std::nullopt;
    Message message =
        make_message(results::MessageClass::explain, results::with_header(results::to_json(*explained), header_of(r)),
                     info.device, info.name);
    message.kind = info.kind;
    const nlohmann::json& explanation = message.body;
    outbox_.post(message);
    // Kept beside the recording for the session's report (guideway report reads it too). The
    // explanation was published: a disk that refuses the copy is a recording error, not a failed one.
    const std::string path = state_dir_ + "/" + info.name + ".explain.json";
    try {
      write_file_atomically(path, explanation.dump(1) + "\n", sessions::recording_file_mode);
    } catch (const std::exception& e) {
      report_recording_error(r, r.info.recording_error.empty() ? e.what() : r.info.recording_error + "; " + e.what());
      return std::nullopt;
    }
    return path;
  } catch (const std::exception& e) {
    post_event(info, "explain_failed", e.what());
    return std::nullopt;
  }
}

void SessionManager::write_session_report(const Running& r, std::vector<std::string> inputs,
                                          SessionAnalysis& analysis) {
  // Every session ends with exactly one of report_ready and report_failed: a client waiting for one
  // must not hang.
  if (inputs.empty()) {
    post_event(r.info, "report_failed",
               r.info.recording_error.empty()
                   ? "no report: the session wrote no files to report on"
                   : "no report: the session's files could not be written (" + r.info.recording_error + ")");
    return;
  }
  try {
    SessionReportRequest request{.inputs = std::move(inputs),
                                 .title = "Guideway " + r.info.kind + " session " + r.info.name,
                                 .subtitle = "device " + r.info.device + ", recording " + r.info.recording,
                                 .device = r.info.device,
                                 .instrument = r.instrument,
                                 .checked_on = r.started_on,
                                 .session = r.session.get()};
    const std::string path = report_path(state_dir_, r.info.name);
    analysis.write_report(request, path);
    outbox_.post(make_message(Event{.event = "report_ready", .device = r.info.device, .session = r.info.name, .file = path}));
  } catch (const std::exception& e) {
    post_event(r.info, "report_failed", e.what());
  }
}

std::string report_path(const std::string& state_dir, const std::string& session) {
  return state_dir + "/" + session + ".report.html";
}

std::vector<std::string> SessionManager::write_derived(Running& r, std::string& error) {
  try {
    std::vector<std::string> derived = r.session->write_derived(state_dir_, r.info.name);
    for (const auto& path : derived) ::chmod(path.c_str(), sessions::recording_file_mode);
    return derived;
  } catch (const std::exception& e) {
    error = e.what();
    return {};
  }
}

void SessionManager::finish(std::unique_ptr<Running> r) {
  SessionInfo& info = r->info;
  results::Params params;
  std::string failure;
  // A session identified from its derived files (the DBB run files) is analysed in a process of its own:
  // its files are written first, for it to read.
  std::vector<std::string> derived;
  std::string derived_error;
  bool derived_written = false;
  std::unique_ptr<SessionAnalysis> analysis;
  if (!analysis_executable_.empty() && r->recorder && r->session->identifies_from_derived()) {
    derived = write_derived(*r, derived_error);
    derived_written = true;
    if (!derived.empty()) {
      const drivers::Driver& device = *devices_[r->device_index];
      AnalysisSubject subject{.request = {info.kind, info.device, r->options, r->instrument},
                              .device = device.name(),
                              .driver = device.driver(),
                              .channels = device.channels(),
                              .explain_memory_mb = explain_memory_mb_,
                              .derived = derived};
      try {
        analysis = analysis_in_process(analysis_executable_, subject);
      } catch (const std::exception& e) {
        failure = e.what();
      }
    }
  }
  // Else (and for a session that traced nothing to write: it fails at once) in the daemon.
  if (!analysis && failure.empty()) analysis = analysis_in_daemon(*r->session, report_renderer_);
  if (analysis) {
    try {
      params = analysis->identify();
    } catch (const std::exception& e) {
      failure = e.what();
    }
  }
  if (r->recorder) {
    std::map<std::string, std::string> trailer;
    if (!failure.empty()) trailer["identification_error"] = failure;
    info.recording = r->recorder->close(failure.empty(), trailer);
    // close() leaves NAME.csv.part when the disk refused the rest. A disk that recovered in time
    // (the recorder kept the data in memory) leaves a whole recording: no error stays then.
    const sessions::RecorderStats written = r->recorder->stats();
    if (std::string e = r->recorder->error(); !e.empty()) {
      report_recording_error(*r, e);
    } else if (written.samples_lost != 0) {
      report_recording_error(*r, info.recording + ": " + std::to_string(written.samples_lost) +
                                     " samples lost (the recorder fell behind or the disk refused writes too long)");
    } else {
      info.recording_error.clear();
    }
    if (!derived_written) derived = write_derived(*r, derived_error);
    // Both are kept: the raw recording's error is the one that loses data.
    if (!derived_error.empty())
      report_recording_error(*r, info.recording_error.empty() ? derived_error
                                                              : info.recording_error + "; " + derived_error);
  }
  info.state = failure.empty() ? SessionState::done : SessionState::failed;
  if (failure.empty()) {
    results::ResultHeader header = header_of(*r);
    header.samples = info.samples;
    header.recording = info.recording;
    header.recording_error = info.recording_error;
    header.derived = derived;
    Message message = make_message(results::MessageClass::params,
                                   results::with_header(results::to_json(params), header), info.device, info.name);
    message.kind = info.kind;
    message.axis = params.axis;
    outbox_.post(std::move(message));
    if (const auto explanation = post_explanation(*r, *analysis)) derived.push_back(*explanation);
    write_session_report(*r, derived, *analysis);
  }
  analysis.reset();  // a child's input ends: it exits and is reaped
  {
    std::lock_guard lock(mutex_);
    for (auto& i : infos_) {
      if (i.name == info.name) {
        i = info;
        if (!failure.empty()) i.progress = failure;
      }
    }
  }
  // After STATUS shows the failure: a client that hears of it and asks (params) is told why.
  if (!failure.empty()) {
    post_event(info, "session_failed", failure);
    post_event(info, "report_failed", "no report: identification failed: " + failure);  // one of the two, always
  }
}

}  // namespace guideway::daemon
