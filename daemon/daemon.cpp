// guidewayd wired together (daemon.hpp): drivers, pipeline, sessions, socket server, emulators, the requests' handlers.
#include "daemon/daemon.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/eventfd.h>
#include <sys/file.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include "core/mono_clock.hpp"
#include "core/number_format.hpp"
#include "core/runtime_paths.hpp"
#include "core/utc_time.hpp"
#include "formats/raw_recording.hpp"
#include "results/explanation.hpp"
#include "results/result_header.hpp"

namespace guideway::daemon {

std::vector<std::unique_ptr<drivers::Driver>> create_devices(const DaemonConfig& config,
                                                             const drivers::DriverRegistry& registry) {
  std::vector<std::unique_ptr<drivers::Driver>> devices;
  for (const auto& dev : config.devices) {
    devices.push_back(registry.create({dev.name, dev.driver, dev.ring_capacity, *dev.table}));
    dev.table->reject_unknown_keys();
  }
  return devices;
}

std::vector<std::vector<DenoiserSpec>> processing_steps(const DaemonConfig& config,
                                                        const std::vector<std::unique_ptr<drivers::Driver>>& devices) {
  std::vector<std::vector<DenoiserSpec>> out(devices.size());
  for (const auto& p : config.processing) {
    const auto device =
        std::find_if(devices.begin(), devices.end(), [&](const auto& d) { return d->name() == p.device; });
    if (device == devices.end()) p.table->fail("device", "no device is named \"" + p.device + "\"");
    const auto& channels = (*device)->channels();
    const auto channel =
        std::find_if(channels.begin(), channels.end(), [&](const auto& c) { return c.name == p.channel; });
    if (channel == channels.end()) {
      std::string known;
      for (const auto& c : channels) known += (known.empty() ? "" : ", ") + c.name;
      p.table->fail("channel",
                    "device \"" + p.device + "\" has no channel \"" + p.channel + "\" (it has: " + known + ")");
    }
    DenoiserSpec spec;
    spec.channel = static_cast<std::size_t>(channel - channels.begin());
    spec.channel_name = p.channel;
    spec.wavelet = p.wavelet;
    spec.options.levels = p.levels;
    spec.options.denoise_options.rule = dsp::parse_threshold_rule(p.threshold);
    spec.options.denoise_options.level_dependent = p.level_dependent;
    spec.options.denoise_options.window = p.noise_window;
    out[static_cast<std::size_t>(device - devices.begin())].push_back(std::move(spec));
  }
  return out;
}

// [[session_trigger]] tables as the session manager's triggers: their device and channel found, their session's
// options checked now (a session that could not begin is a configuration error, not a surprise at the pin).
std::vector<SessionManager::Trigger> session_triggers(const DaemonConfig& config,
                                                      const std::vector<std::unique_ptr<drivers::Driver>>& devices,
                                                      const sessions::SessionRegistry& registry) {
  std::vector<SessionManager::Trigger> out;
  const auto named = [&](const std::string& name) {
    return std::find_if(devices.begin(), devices.end(), [&](const auto& d) { return d->name() == name; });
  };
  for (const auto& t : config.session_triggers) {
    const auto device = named(t.device);
    if (device == devices.end()) t.table->fail("device", "no device is named \"" + t.device + "\"");
    const auto& channels = (*device)->channels();
    const auto channel =
        std::find_if(channels.begin(), channels.end(), [&](const auto& c) { return c.name == t.channel; });
    if (channel == channels.end()) {
      std::string known;
      for (const auto& c : channels) known += (known.empty() ? "" : ", ") + c.name;
      t.table->fail("channel", "device \"" + t.device + "\" has no channel \"" + t.channel + "\" (it has: " + known + ")");
    }
    SessionManager::Trigger trig;
    trig.device_index = static_cast<std::size_t>(device - devices.begin());
    trig.channel = static_cast<std::size_t>(channel - channels.begin());
    trig.pin = t.device + "." + t.channel;
    trig.request.kind = t.kind;
    trig.request.device = t.on_device;
    trig.request.options = nlohmann::json::parse(t.options);
    trig.end_after_s = t.end_after_s;
    const sessions::SessionKind* kind = registry.find(t.kind);
    if (!kind) t.table->fail("kind", "no session kind \"" + t.kind + "\"");
    const auto target = t.on_device.empty()
                            ? std::find_if(devices.begin(), devices.end(),
                                           [&](const auto& d) {
                                             return std::find(kind->drivers.begin(), kind->drivers.end(),
                                                              d->driver()) != kind->drivers.end();
                                           })
                            : named(t.on_device);
    if (target == devices.end()) t.table->fail("session_device", "no device here can run a " + t.kind + " session");
    try {
      (void)kind->create(trig.request, **target);
    } catch (const std::invalid_argument& e) {
      t.table->fail("options", e.what());
    }
    out.push_back(std::move(trig));
  }
  return out;
}

Daemon::InstanceLock::InstanceLock(const std::string& socket_path) {
  if (socket_path.empty()) return;  // no Unix socket: nothing shared to guard
  const std::string path = socket_path + ".lock";
  secure_socket_directory(std::filesystem::path(path).parent_path().string());
  // O_NOFOLLOW: a symlink planted as the lock would make us create or lock a file elsewhere.
  fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0600);
  if (fd < 0) throw std::system_error(errno, std::generic_category(), "open " + path);
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    ::close(fd);
    if (err == EWOULDBLOCK)
      throw std::runtime_error("another daemon is already listening on " + socket_path + " (it holds " + path + ")");
    throw std::system_error(err, std::generic_category(), "flock " + path);
  }
}

Daemon::InstanceLock::~InstanceLock() {
  if (fd >= 0) ::close(fd);
}

Daemon::Daemon(DaemonConfig config, drivers::DriverRegistry& registry, const sessions::SessionRegistry& sessions,
               std::shared_ptr<spdlog::logger> logger, DaemonOptions options)
    : config_(std::move(config)),
      log_(std::move(logger)),
      options_(options),
      instance_lock_(config_.socket_path),
      outbox_(65536) {
  // Before the emulators start: theirs would replace the running daemon's endpoints (CAN socket,
  // pty link) in the same runtime directory, and its devices could not reconnect.
  if (unix_socket_answers(config_.socket_path)) {
    throw std::runtime_error("another daemon is already listening on " + config_.socket_path);
  }
  emulators_ = launch_emulators(config_);
  emulator_watch_.resize(emulators_.size());
  for (const auto& e : emulators_) log_->info("emulator {} (pid {}) serves {}", e->name(), e->pid(), e->endpoint());
  devices_ = create_devices(config_, registry);
  std::vector<drivers::Driver*> raw;
  for (auto& d : devices_) raw.push_back(d.get());
  last_states_.assign(devices_.size(), drivers::DeviceState::stopped);
  pipeline_ = std::make_unique<Pipeline>(raw, outbox_, config_.sample_publish_hz, io_);
  const auto steps = processing_steps(config_, devices_);
  auto manager = std::make_unique<SessionManager>(sessions, raw, config_.state_dir, outbox_);
  std::vector<Instrument> instruments;
  for (const auto& d : config_.devices) instruments.push_back(d.instrument);  // create_devices' order
  manager->set_instruments(std::move(instruments), config_.refuse_uncalibrated);
  if (config_.explain_memory_mb) manager->set_explain_memory_mb(*config_.explain_memory_mb);
  manager->set_report_renderer(options_.session_report);
  if (config_.session_analysis == "process") {
    manager->set_analysis_executable(config_.analysis_executable.empty() ? options_.analysis_executable
                                                                         : config_.analysis_executable);
  }
  manager->set_triggers(session_triggers(config_, devices_, sessions));
  sessions_ = manager.get();
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    pipeline_->set_processing(i, steps[i]);
  }
  pipeline_->add_stage(std::move(manager));

  SocketServerOptions so;
  so.unix_path = config_.socket_path;
  so.unix_mode = config_.socket_mode;
  so.unix_group = config_.socket_group;
  so.tcp_host = config_.tcp_host;
  so.tcp_port = config_.tcp_port;
  so.max_request_bytes = config_.max_request_bytes;
  so.max_queue_bytes = config_.client_queue_bytes;
  so.max_clients = config_.max_clients;
  so.reserved_clients = config_.reserved_clients;
  server_ = std::make_unique<SocketServer>(loop_, so);
  if (config_.mqtt) {
    plant::PublisherSettings mqtt = *config_.mqtt;
    mqtt.held_back_event = [per_minute = mqtt.events_per_minute](const std::string& device, std::uint64_t count) {
      return make_message(Event{.event = "events_dropped",
                                .time = utc_now_iso(),
                                .device = device,
                                .reason = std::to_string(count) + " event(s) not sent to the MQTT broker: more than " +
                                          shortest(per_minute) + " a minute (events_per_minute)",
                                .device_news = true})
          .line;
    };
    mqtt_ = std::make_unique<plant::Publisher>(std::move(mqtt), log_);
  }
  server_->on_connect([this](ClientId id) {
    subscriptions_[id] = {};
    server_->send(id, version_message().dump());
  });
  server_->on_disconnect([this](ClientId id, const std::string& reason) {
    subscriptions_.erase(id);
    if (reason != "closed by peer" && reason != "server shutting down") {
      std::uint64_t more = 0;
      if (dropped_log_.allow(reason, mono_now_ns(), more))
        log_->warn(
            "client {} dropped: {}{}", id, reason,
            more ? " (and " + std::to_string(more) + " more for this reason in the last minute, not logged)" : "");
    } else {
      log_->debug("client {} gone: {}", id, reason);
    }
  });
  server_->on_request([this](ClientId id, const std::string& line) { handle_request(id, line); });
  server_->on_oversize([this](ClientId id, std::size_t bytes, bool whole) {
    const std::string limit = std::to_string(config_.max_request_bytes);
    server_->send(id, error_message(whole ? "request of " + std::to_string(bytes) + " bytes exceeds the limit of " +
                                                limit + " bytes"
                                          : "request of more than " + limit + " bytes (no end of line after " +
                                                std::to_string(bytes) + ") exceeds the limit of " + limit +
                                                " bytes; the rest of the line is discarded")
                          .dump());
  });

  stop_fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (stop_fd_ < 0) throw std::system_error(errno, std::generic_category(), "eventfd");
  loop_.add(stop_fd_, EPOLLIN, [this](std::uint32_t) { loop_.stop(); });
  if (options_.handle_signals) {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGINT);
    signal_fd_ = signalfd(-1, &set, SFD_NONBLOCK | SFD_CLOEXEC);
    if (signal_fd_ < 0) throw std::system_error(errno, std::generic_category(), "signalfd");
    loop_.add(signal_fd_, EPOLLIN, [this](std::uint32_t) {
      signalfd_siginfo info{};
      if (read(signal_fd_, &info, sizeof(info)) == sizeof(info)) {
        log_->info("received {}, shutting down", strsignal(static_cast<int>(info.ssi_signo)));
      }
      loop_.stop();
    });
  }
  loop_.add(outbox_.fd(), EPOLLIN, [this](std::uint32_t) {
    const SocketServer::Batch batch(*server_);  // one write per client for the whole outbox batch
    for (Message& m : outbox_.take()) {
      if (m.cls == results::MessageClass::params) {
        // The newest per kind, and per axis for a kind whose sessions name one (a traverse of each carriage).
        std::erase_if(latest_params_, [&](const LatestResult& p) { return p.kind == m.kind && p.axis == m.axis; });
        latest_params_.push_back({m.kind, m.axis, m.session, m.body});
        log_->info("session {}: parameters identified", m.session);
      } else if (m.cls == results::MessageClass::explain) {
        std::erase_if(latest_explain_, [&](const LatestResult& p) { return p.kind == m.kind; });
        try {  // the session manager's own results::to_json: read back as the type
          const results::Explanation e = results::explanation_from_json(m.body);
          log_->info("session {}: {} finding(s){}", m.session, e.findings.size(),
                     e.unexplained ? ", a structured residual is left unexplained" : "");
        } catch (const results::ExplanationFormatError& e) {
          log_->warn("session {}: its EXPLAIN does not read back: {}", m.session, e.what());
        }
        latest_explain_.push_back({m.kind, m.axis, m.session, m.body});
      } else if (m.cls == results::MessageClass::event) {
        const nlohmann::json& j = m.body;
        if (j.contains("session")) {
          // A failure carries its reason (a warning); news such as report_ready carries its file (info).
          if (j.contains("reason"))
            log_->warn("session {}: {}: {}", j.value("session", "?"), j.value("event", "?"), j.value("reason", ""));
          else
            log_->info("session {}: {}{}", j.value("session", "?"), j.value("event", "?"),
                       j.contains("file") ? ": " + j.value("file", "") : "");
        }
      }
      broadcast(m);
    }
  });
}

Daemon::~Daemon() {
  pipeline_->stop();
  for (auto& d : devices_) d->stop();
  io_.stop();
  server_.reset();
  if (stop_fd_ >= 0) close(stop_fd_);
  if (signal_fd_ >= 0) close(signal_fd_);
}

void Daemon::request_stop() noexcept {
  const std::uint64_t one = 1;
  [[maybe_unused]] auto ignored = write(stop_fd_, &one, sizeof(one));
}

int Daemon::run() {
  started_ns_ = mono_now_ns();
  io_.start("gw-io");
  for (auto& d : devices_) d->start(&io_);
  pipeline_->start();
  log_->info("guidewayd {} listening on {}{}; {} device(s); config {}", GUIDEWAY_VERSION, config_.socket_path,
             server_->tcp_port() ? " and " + config_.tcp_host + ":" + std::to_string(server_->tcp_port()) : "",
             devices_.size(), config_.source);
  if (server_->tcp_port() != 0 && !config_.tcp_host.starts_with("127.")) {
    // Configured deliberately (tcp_listen), but worth a line: the socket has no authentication.
    log_->warn("TCP on {}:{} is reachable from other hosts: anyone who can connect can start and stop sessions",
               config_.tcp_host, server_->tcp_port());
  }
  for (const std::string& w : calibration_warnings(config_, utc_today()))
    log_->warn("{}{}", w, config_.refuse_uncalibrated ? " (refuse_uncalibrated: its sessions are refused)" : "");
  notifier_.ready(status_line());
  loop_.run(50, [this] { periodic(mono_now_ns()); });
  notifier_.stopping();
  log_->info("stopping");
  pipeline_->stop();
  for (auto& d : devices_) d->stop();
  io_.stop();
  return 0;
}

void Daemon::periodic(std::int64_t now_ns) {
  notifier_.watchdog(pipeline_->progress(), now_ns);
  check_device_events();
  check_emulators(now_ns);
  server_->close_idle(now_ns, static_cast<std::int64_t>(config_.idle_timeout_s * 1e9));
  if (now_ns - last_status_ns_ >= static_cast<std::int64_t>(config_.status_period_s * 1e9)) {
    last_status_ns_ = now_ns;
    last_stats_ = pipeline_->take_stats();
    nlohmann::json status = status_json();
    if (mqtt_) {
      mqtt_->publish_devices(
          results::with_class(results::MessageClass::status, {{"time", status["time"]}, {"devices", status["devices"]}})
              .dump());
    }
    broadcast(make_message(results::MessageClass::status, std::move(status)));
    notifier_.status(status_line());
  }
}

void Daemon::check_emulators(std::int64_t now_ns) {
  for (std::size_t i = 0; i < emulators_.size(); ++i) {
    EmulatorProcess& e = *emulators_[i];  // replaced on a restart: nothing below uses it after that
    const std::string name = e.name();
    EmulatorWatch& w = emulator_watch_[i];
    const auto event = [&](const std::string& what, const std::string& reason) {
      broadcast(make_message(Event{.event = what, .time = utc_now_iso(), .emulator = name, .reason = reason}));
    };
    if (w.state == "running") {
      const std::string how = e.reap();  // no zombie under guidewayd
      if (how.empty()) continue;
      w.state = "exited";
      w.last_exit = how;
      const double wait_s = w.backoff.take_s();
      w.restart_at_ns = now_ns + static_cast<std::int64_t>(wait_s * 1e9);
      log_->warn("emulator {} exited ({}); restarting it in {} s", e.name(), how, wait_s);
      event("emulator_exited", how);
      continue;
    }
    if (now_ns < w.restart_at_ns) continue;
    try {
      // At the endpoint it served, so the devices configured with it find it again; a short wait for
      // its endpoint line (this is the event loop).
      emulators_[i] = std::make_unique<EmulatorProcess>(e.executable(), e.restart_spec(), std::chrono::seconds(2));
      ++w.restarts;
      w.state = "running";
      w.backoff.reset();
      log_->info("emulator {} restarted (pid {}) at {}", emulators_[i]->name(), emulators_[i]->pid(),
                 emulators_[i]->endpoint());
      event("emulator_restarted", "");
    } catch (const std::exception& ex) {
      const double wait_s = w.backoff.take_s();
      w.restart_at_ns = now_ns + static_cast<std::int64_t>(wait_s * 1e9);
      log_->warn("emulator {}: restart failed ({}); next try in {} s", name, ex.what(), wait_s);
      event("emulator_restart_failed", ex.what());
    }
  }
}

nlohmann::json Daemon::mqtt_json() const {
  if (!mqtt_) return nullptr;
  const plant::PublisherStats s = mqtt_->stats();
  nlohmann::json j = {{"broker", s.broker},
                      {"machine", mqtt_->settings().machine},
                      {"topic_prefix", mqtt_->settings().topic_prefix},
                      {"state", s.state},
                      {"since", s.since},
                      {"queued", s.queued},
                      {"delivered", s.delivered},
                      {"dropped", s.dropped},
                      {"dropped_results", s.dropped_results},
                      {"dropped_transitions", s.dropped_transitions},
                      {"dropped_events", s.dropped_events},
                      {"rate_limited", s.rate_limited},
                      {"refused", s.refused},
                      {"reconnects", s.reconnects}};
  if (!s.last_error.empty()) j["last_error"] = s.last_error;
  return j;
}

nlohmann::json Daemon::emulators_json() const {
  nlohmann::json a = nlohmann::json::array();
  for (std::size_t i = 0; i < emulators_.size(); ++i) {
    const auto& e = *emulators_[i];
    const auto& w = emulator_watch_[i];
    nlohmann::json j = {{"name", e.name()},
                        {"instrument", e.spec().instrument},
                        {"endpoint", e.endpoint()},
                        {"state", w.state},
                        {"restarts", w.restarts}};
    if (w.state == "running") j["pid"] = e.pid();
    if (!w.last_exit.empty()) j["last_exit"] = w.last_exit;
    a.push_back(std::move(j));
  }
  return a;
}

void Daemon::check_device_events() {
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    // What happened inside the device (a CANopen node's EMCY or reboot), in order, before its state.
    for (const drivers::DeviceEvent& e : devices_[i]->take_events()) {
      if (e.warning)
        log_->warn("device {}: {}: {}", devices_[i]->name(), e.event, e.reason);
      else
        log_->info("device {}: {}: {}", devices_[i]->name(), e.event, e.reason);
      broadcast(make_message(Event{.event = e.event,
                                   .time = utc_now_iso(),
                                   .device = devices_[i]->name(),
                                   .reason = e.reason,
                                   .device_news = true}));
    }
    const drivers::DriverStatus s = devices_[i]->status();
    if (s.state == last_states_[i]) continue;
    last_states_[i] = s.state;
    if (s.state == drivers::DeviceState::lost || s.state == drivers::DeviceState::error) {
      log_->warn("device {}: {}{}", s.name, drivers::to_string(s.state), s.reason.empty() ? "" : ": " + s.reason);
    } else {
      log_->info("device {}: {}{}", s.name, drivers::to_string(s.state), s.reason.empty() ? "" : ": " + s.reason);
    }
    broadcast(make_message(Event{.event = std::string(drivers::to_string(s.state)),
                                 .time = utc_now_iso(),
                                 .device = s.name,
                                 .reason = s.reason}));
  }
}

std::string Daemon::status_line() const {
  std::size_t streaming = 0;
  for (const auto& d : devices_) streaming += d->status().state == drivers::DeviceState::streaming ? 1 : 0;
  const std::size_t expired = calibration_warnings(config_, utc_today()).size();
  return std::to_string(streaming) + "/" + std::to_string(devices_.size()) + " devices streaming, " +
         std::to_string(server_->client_count()) + " clients" +
         (expired ? ", " + std::to_string(expired) + " past calibration due" : "");
}

nlohmann::json Daemon::status_json() {
  const std::vector<DeviceFlowStats> flow = pipeline_->device_flow();
  nlohmann::json devices = nlohmann::json::array();
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    const drivers::DriverStatus s = devices_[i]->status();
    nlohmann::json d = {{"name", s.name}, {"driver", s.driver}, {"state", std::string(drivers::to_string(s.state))}};
    if (!s.reason.empty()) d["reason"] = s.reason;
    add_instrument_status(i, s, d);
    d["counters"] = {{"samples", s.counters.samples},       {"frames", s.counters.frames},
                     {"bad_frames", s.counters.bad_frames}, {"timeouts", s.counters.timeouts},
                     {"reconnects", s.counters.reconnects}, {"overruns", s.counters.overruns}};
    nlohmann::json own = nlohmann::json::object();  // the driver's own counters: always an object, maybe empty
    for (const auto& c : s.driver_counters) own[c.name] = c.value;
    d["driver_counters"] = std::move(own);
    d["ring"] = {
        {"capacity", s.ring.capacity}, {"depth", s.ring.depth}, {"free", s.ring.free}, {"drops", s.ring.drops}};
    nlohmann::json channels = nlohmann::json::array();
    for (const auto& c : devices_[i]->channels()) channels.push_back({{"name", c.name}, {"unit", c.unit}});
    d["channels"] = std::move(channels);
    nlohmann::json processing = nlohmann::json::array();
    for (const auto& p : pipeline_->processing(i).steps()) {
      processing.push_back({{"channel", devices_[i]->channels().at(p->channel()).name},
                            {"step", "wavelet_denoise"},
                            {"wavelet", p->wavelet().name()},
                            {"levels", p->levels()},
                            {"latency_samples", p->latency_samples()},
                            {"passed_through", p->passed_through()},
                            {"restarts", p->restarts()}});
    }
    if (!processing.empty()) d["processing"] = std::move(processing);
    if (i < flow.size()) {
      d["consumed"] = flow[i].consumed;
      d["seq_gaps"] = flow[i].seq_gaps;
    }
    devices.push_back(std::move(d));
  }
  return results::with_class(
      results::MessageClass::status,
      {{"time", utc_now_iso()},
       {"release", GUIDEWAY_VERSION},
       {"uptime_s", static_cast<double>(mono_now_ns() - started_ns_) * 1e-9},
       {"config", config_.source},
       {"socket", config_.socket_path},
       {"state_dir", config_.state_dir},
       {"pipeline",
        {{"iterations", last_stats_.iterations},
         {"samples", last_stats_.samples},
         {"latency_mean_us", last_stats_.latency_mean_us},
         {"latency_max_us", last_stats_.latency_max_us},
         {"outbox_dropped", outbox_.dropped()}}},
       {"clients", {{"connected", server_->client_count()}, {"dropped_slow", server_->dropped_clients()}}},
       {"devices", std::move(devices)},
       {"emulators", emulators_json()},
       {"sessions", sessions_json()},
       {"mqtt", mqtt_json()}});
}

void Daemon::reply(ClientId client, nlohmann::json message, const std::optional<nlohmann::json>& id) {
  if (id) message["id"] = *id;
  server_->send(client, message.dump());
}

void Daemon::handle_request(ClientId client, const std::string& line) {
  // The handler of every request class (results::RequestClass); an unknown class gets the list.
  using results::RequestClass;
  struct RequestEntry {
    RequestClass cls;
    nlohmann::json (Daemon::*handle)(ClientId, const Request&);
  };
  static constexpr RequestEntry request_table[] = {
      {RequestClass::version, &Daemon::handle_version}, {RequestClass::status, &Daemon::handle_status},
      {RequestClass::poll, &Daemon::handle_status},     {RequestClass::watch, &Daemon::handle_watch},
      {RequestClass::start, &Daemon::handle_start},     {RequestClass::stop, &Daemon::handle_stop},
      {RequestClass::params, &Daemon::handle_params},   {RequestClass::explain, &Daemon::handle_explain},
      {RequestClass::report, &Daemon::handle_report},   {RequestClass::recordings, &Daemon::handle_recordings},
  };
  RequestError error;
  std::optional<Request> req = parse_request(line, error);
  if (!req) {
    reply(client, error_message(error.message), error.id);
    return;
  }
  const std::optional<RequestClass> cls = results::request_named(req->cls);
  const auto* entry = std::find_if(std::begin(request_table), std::end(request_table),
                                   [&](const RequestEntry& e) { return cls == e.cls; });
  if (entry == std::end(request_table)) {
    reply(client,
          error_message("unknown request class \"" + req->cls + "\" (known: " + results::request_class_names() + ")",
                        req->cls),
          req->id);
    return;
  }
  try {
    reply(client, (this->*entry->handle)(client, *req), req->id);
  } catch (const NotYet& e) {  // a result on its way: said with its session, so a client can wait for it
    nlohmann::json m = error_message(e.what(), req->cls);
    m["pending_session"] = e.session;
    reply(client, std::move(m), req->id);
  } catch (const std::exception& e) {
    reply(client, error_message(e.what(), req->cls), req->id);
  }
}

nlohmann::json Daemon::handle_version(ClientId, const Request&) { return version_message(); }

nlohmann::json Daemon::handle_status(ClientId, const Request&) {
  return status_json();
}

nlohmann::json Daemon::handle_watch(ClientId client, const Request& req) {
  return apply_watch(req.body, subscriptions_[client]);
}

nlohmann::json Daemon::handle_params(ClientId, const Request& req) {
  return latest_of(latest_params_, req, "parameters identified").message;
}

nlohmann::json Daemon::handle_explain(ClientId, const Request& req) {
  return latest_of(latest_explain_, req, "explanation").message;
}

void Daemon::broadcast(const Message& message) {
  if (mqtt_) {  // hands the line over: the publisher's thread does the disk and the network
    if (message.cls == results::MessageClass::params || message.cls == results::MessageClass::explain) {
      mqtt_->publish(
          message.cls == results::MessageClass::params ? plant::TopicLeaf::params : plant::TopicLeaf::explain,
          message.kind.empty() ? "unknown" : message.kind, message.line);
    } else if (message.cls == results::MessageClass::event) {
      // The order of eviction (docs/plant.md): a session's news is a result, a device's inner events go first.
      const plant::JournalShare share = !message.session.empty() ? plant::JournalShare::results
                                        : message.device_news    ? plant::JournalShare::events
                                                                 : plant::JournalShare::transitions;
      mqtt_->publish_event(message.line, share, message.channel);
    }
  }
  // Messages about a session (PARAMS, EXPLAIN, a session's EVENT) also reach whoever watches it by name.
  std::vector<ClientId> targets;
  for (const auto& [id, sub] : subscriptions_) {
    if (sub.wants(message.cls, message.channel, message.session)) targets.push_back(id);
  }
  for (ClientId id : targets) server_->send(id, message.line);  // may drop a slow client
}

}  // namespace guideway::daemon

namespace guideway::daemon {

namespace {

std::string string_field(const nlohmann::json& body, const char* key) {
  auto it = body.find(key);
  if (it == body.end()) return {};
  if (!it->is_string()) throw std::invalid_argument(std::string("\"") + key + "\" must be a string");
  return it->get<std::string>();
}

}  // namespace

void Daemon::add_instrument_status(std::size_t device, const drivers::DriverStatus& s, nlohmann::json& out) const {
  // The configuration's devices are the daemon's, in the same order (create_devices).
  const Instrument& instrument = config_.devices.at(device).instrument;
  const CalendarDate today = utc_today();
  if (!instrument.empty()) out["instrument"] = results::instrument_json(s.name, instrument, today);
  std::vector<std::string> warnings;
  if (std::string w = calibration_warning(s.name, instrument, today); !w.empty())
    warnings.push_back(w + (config_.refuse_uncalibrated ? "; its sessions are refused (refuse_uncalibrated)" : ""));
  else if (config_.refuse_uncalibrated && !instrument.calibration_due)
    warnings.push_back("device " + s.name +
                       ": no calibration_due is configured: its sessions are refused (refuse_uncalibrated)");
  warnings.insert(warnings.end(), s.warnings.begin(), s.warnings.end());  // the driver's (a serial mismatch)
  if (!warnings.empty()) out["warnings"] = std::move(warnings);
}

nlohmann::json Daemon::handle_start(ClientId, const Request& req) {
  sessions::SessionRequest sr;
  sr.kind = string_field(req.body, "kind");
  if (sr.kind.empty())
    throw std::invalid_argument("start needs \"kind\" (e.g. {\"class\":\"start\",\"kind\":\"dbb\"})");
  sr.device = string_field(req.body, "device");
  if (auto it = req.body.find("options"); it != req.body.end()) {
    if (!it->is_object()) throw std::invalid_argument("\"options\" must be an object");
    sr.options = *it;
  }
  const std::string name = sessions_->start(sr);
  log_->info("session {} started", name);
  nlohmann::json reply = {{"session", name}, {"state", to_string(SessionState::running)}};
  for (const SessionInfo& info : sessions_->snapshot()) {
    if (info.name == name) tell_emulated_machine(info.device, sr);
    if (info.name != name || info.warnings.empty()) continue;
    for (const auto& w : info.warnings) log_->warn("session {}: {}", name, w);
    reply["warnings"] = info.warnings;
  }
  return results::with_class(results::MessageClass::session, std::move(reply));
}

void Daemon::tell_emulated_machine(const std::string& device, const sessions::SessionRequest& request) {
  for (const auto& d : config_.devices) {
    if (d.name != device) continue;
    for (const auto& e : emulators_) {
      if (std::find(d.emulators.begin(), d.emulators.end(), e->name()) == d.emulators.end()) continue;
      const std::string command = emulated_machine_command(e->spec().instrument, request.kind, request.options);
      if (command.empty()) continue;
      if (e->command(command))
        log_->info("emulator {}: {} (the session's)", e->name(), command);
      else
        log_->warn("emulator {}: could not send \"{}\": it runs its own program", e->name(), command);
    }
  }
}

nlohmann::json Daemon::handle_stop(ClientId, const Request& req) {
  const auto names = sessions_->stop(string_field(req.body, "session"));
  return results::with_class(results::MessageClass::session,
                             {{"sessions", names}, {"state", to_string(SessionState::finishing)}});
}

const Daemon::LatestResult& Daemon::latest_of(const std::vector<LatestResult>& latest, const Request& req,
                                              const std::string& what) const {
  const std::string kind = string_field(req.body, "kind");
  const std::string session = string_field(req.body, "session");
  const std::string axis = string_field(req.body, "axis");
  const auto matches = [&](const LatestResult& r) {
    return (kind.empty() || r.kind == kind) && (session.empty() || r.session == session) &&
           (axis.empty() || r.axis == axis);
  };
  // The newest session asked for says why there is none, or that it is on its way: it runs, it is being
  // finished (its PARAMS out, its EXPLAIN still computed: an older session's would be the wrong one), or it
  // failed; only without one is the user sent to start one.
  const auto infos = sessions_->snapshot();
  const auto newest = std::find_if(infos.rbegin(), infos.rend(), [&](const SessionInfo& i) {
    return (kind.empty() || i.kind == kind) && (session.empty() || i.name == session);
  });
  const std::string none = "no " + what + " yet" + (kind.empty() ? std::string() : " for " + kind);
  if (newest != infos.rend() && newest->state == SessionState::finishing &&
      std::none_of(latest.begin(), latest.end(), [&](const LatestResult& r) { return r.session == newest->name; }))
    throw NotYet(none + ": session " + newest->name + " has ended and is being finished (identified, explained, "
                     "reported); ask again in moments",
                 newest->name);
  for (auto it = latest.rbegin(); it != latest.rend(); ++it) {
    if (matches(*it)) return *it;
  }
  if (!axis.empty() && kind == "straightness")
    throw std::invalid_argument("no " + what + " yet for a straightness traverse of " + axis +
                                " (start one: guideway start straightness --set axis=" + axis + ")");
  if (!kind.empty() && !sessions_->known_kind(kind)) {
    throw std::invalid_argument("unknown session kind \"" + kind + "\" (known: " + sessions_->kinds() + ")");
  }
  if (newest != infos.rend() && newest->state == SessionState::running)
    throw NotYet(none + ": session " + newest->name + " is still running", newest->name);
  if (!session.empty()) throw std::invalid_argument("no " + what + " for session \"" + session + "\"");
  for (auto it = infos.rbegin(); it != infos.rend(); ++it) {
    if ((kind.empty() || it->kind == kind) && it->state == SessionState::failed)
      throw std::invalid_argument(none + ": session " + it->name + " failed: " + it->progress);
  }
  throw std::invalid_argument(none + " (start a session: guideway start " + (kind.empty() ? "KIND" : kind) + ")");
}

nlohmann::json Daemon::handle_report(ClientId, const Request& req) {
  const LatestResult& params = latest_of(latest_params_, req, "session finished");
  const std::string session = params.session;
  const std::string path = report_path(config_.state_dir, session);
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const auto infos = sessions_->snapshot();
    if (std::any_of(infos.begin(), infos.end(), [&](const SessionInfo& i) {
          return i.name == session && i.state == SessionState::finishing;
        }))
      throw NotYet("the report of session " + session + " is being written; ask again in moments", session);
    throw std::invalid_argument("no report for session " + session + " (" + path + " is missing: see the log)");
  }
  std::ostringstream html;
  html << in.rdbuf();
  return results::with_class(
      results::MessageClass::report,
      {{"session", session}, {"kind", params.kind}, {"file", path}, {"html", html.str()}});
}

nlohmann::json Daemon::handle_recordings(ClientId, const Request&) {
  // Raw recordings only (what `guideway replay` reads): a session's derived files (DBB runs, the
  // traverse, ...) are CSV too, and are named in its PARAMS.
  nlohmann::json list = nlohmann::json::array();
  for (const auto& e : formats::list_raw_recordings(config_.state_dir)) {
    list.push_back({{"file", e.path}, {"bytes", e.bytes}, {"complete", e.complete}});
  }
  return results::with_class(results::MessageClass::recordings,
                             {{"dir", config_.state_dir}, {"recordings", std::move(list)}});
}

nlohmann::json Daemon::sessions_json() const {
  nlohmann::json out = nlohmann::json::array();
  for (const SessionInfo& s : sessions_->snapshot()) {
    nlohmann::json j = {{"session", s.name},
                        {"kind", s.kind},
                        {"device", s.device},
                        {"state", to_string(s.state)},
                        {"samples", s.samples}};
    if (!s.progress.empty()) j["progress"] = s.progress;
    if (s.time_left_s && s.state == SessionState::running) j["time_left_s"] = std::round(*s.time_left_s * 10) / 10;
    if (!s.recording.empty()) j["recording"] = s.recording;
    if (!s.recording_error.empty()) j["recording_error"] = s.recording_error;
    if (!s.warnings.empty()) j["warnings"] = s.warnings;
    out.push_back(std::move(j));
  }
  return out;
}

}  // namespace guideway::daemon
