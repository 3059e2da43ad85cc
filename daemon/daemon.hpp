#pragma once
// guidewayd wired together: drivers from the configuration, the pipeline, the socket server and the
// systemd glue, on one event loop. run() blocks until request_stop() (thread safe) or, when
// handle_signals is set, SIGTERM/SIGINT (which the caller must have blocked before starting threads).

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include <spdlog/logger.h>

#include "core/backoff.hpp"
#include "daemon/channel_denoiser.hpp"
#include "daemon/config.hpp"
#include "daemon/event_loop.hpp"
#include "daemon/logging.hpp"
#include "daemon/outbox.hpp"
#include "daemon/pipeline.hpp"
#include "daemon/protocol.hpp"
#include "daemon/session_manager.hpp"
#include "daemon/socket_server.hpp"
#include "daemon/systemd_notify.hpp"
#include "drivers/driver.hpp"
#include "drivers/io_loop.hpp"
#include "plant/publisher.hpp"

namespace guideway::daemon {

struct DaemonOptions {
  bool handle_signals = false;
  // How finished sessions' reports are rendered (guidewayd: daemon/reports/session_report.hpp); none: each
  // session's end posts report_failed saying so.
  SessionReportRenderer session_report;
  // The program that analyses a finished session in a process of its own ([daemon] session_analysis =
  // "process"; guidewayd: itself). None, and no [daemon] analysis_executable: every session in the daemon.
  std::string analysis_executable;
};

// Creates a driver for every [[device]] table (not started); throws ConfigError naming the file, line
// and key for an unknown driver, a bad value or a key the driver does not read.
std::vector<std::unique_ptr<drivers::Driver>> create_devices(const DaemonConfig& config,
                                                             const drivers::DriverRegistry& registry);

// The [[processing]] steps of each created device (indexed like `devices`); throws ConfigError naming
// the file, line and key when a channel is not one of the device's.
std::vector<std::vector<DenoiserSpec>> processing_steps(const DaemonConfig& config,
                                                        const std::vector<std::unique_ptr<drivers::Driver>>& devices);

class Daemon {
 public:
  // Creates the drivers (throws ConfigError on a bad [[device]] table) and binds the sockets
  // (throws std::runtime_error/std::system_error naming the path on failure). Nothing runs yet.
  Daemon(DaemonConfig config, drivers::DriverRegistry& registry, const sessions::SessionRegistry& sessions,
         std::shared_ptr<spdlog::logger> logger, DaemonOptions options = {});
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  int run();
  void request_stop() noexcept;
  [[nodiscard]] const SocketServer& server() const { return *server_; }
  [[nodiscard]] nlohmann::json status_json();

 private:
  void handle_request(ClientId client, const std::string& line);
  void reply(ClientId client, nlohmann::json message, const std::optional<nlohmann::json>& id);
  void broadcast(const Message& message);
  void periodic(std::int64_t now_ns);
  void check_device_events();
  // Emulator children that exited: reaped, logged, an EVENT, restarted with back-off.
  void check_emulators(std::int64_t now_ns);
  [[nodiscard]] nlohmann::json emulators_json() const;
  // A session began on `device`: the emulators serving it are told what it asks of the machine
  // (emulated_machine_command: the DBB emulator's circles at the session's feed).
  void tell_emulated_machine(const std::string& device, const sessions::SessionRequest& request);
  [[nodiscard]] nlohmann::json mqtt_json() const;
  // One request class each (the table in daemon.cpp dispatches them and lists them); an exception is
  // the ERROR's reason.
  nlohmann::json handle_version(ClientId client, const Request& req);
  nlohmann::json handle_status(ClientId client, const Request& req);
  nlohmann::json handle_watch(ClientId client, const Request& req);
  nlohmann::json handle_start(ClientId client, const Request& req);
  nlohmann::json handle_stop(ClientId client, const Request& req);
  nlohmann::json handle_params(ClientId client, const Request& req);
  nlohmann::json handle_explain(ClientId client, const Request& req);
  nlohmann::json handle_report(ClientId client, const Request& req);
  nlohmann::json handle_recordings(ClientId client, const Request& req);
  // The newest message of `latest` matching the request's optional kind/session; throws naming `what`.
  // A result a session of the kind will publish, not yet there: the request's ERROR names the session.
  struct NotYet : std::invalid_argument {
    NotYet(const std::string& what, std::string pending) : std::invalid_argument(what), session(std::move(pending)) {}
    std::string session;
  };
  // The newest PARAMS or EXPLAIN of a session kind (and axis), as published (answered byte for byte).
  struct LatestResult {
    std::string kind;
    std::string axis;  // a traverse's PARAMS: its machine axis
    std::string session;
    nlohmann::json message;
  };
  const LatestResult& latest_of(const std::vector<LatestResult>& latest, const Request& req,
                                const std::string& what) const;
  nlohmann::json sessions_json() const;
  // A STATUS device's "instrument" (as configured, judged today) and "warnings" (calibration run out,
  // the driver's own: a serial that is not the configured one).
  void add_instrument_status(std::size_t device, const drivers::DriverStatus& s, nlohmann::json& out) const;
  std::string status_line() const;

  // An exclusive flock on SOCKET_PATH.lock held for the daemon's life, taken before anything starts:
  // two daemons started at once on one path cannot both pass the "nobody answers" check.
  struct InstanceLock {
    int fd = -1;
    explicit InstanceLock(const std::string& socket_path);
    ~InstanceLock();
    InstanceLock(const InstanceLock&) = delete;
    InstanceLock& operator=(const InstanceLock&) = delete;
  };

  DaemonConfig config_;
  std::shared_ptr<spdlog::logger> log_;
  DaemonOptions options_;
  InstanceLock instance_lock_;  // before the emulators, the devices and the socket: released last
  std::vector<std::unique_ptr<EmulatorProcess>> emulators_;  // before devices_: outlives the drivers
  struct EmulatorWatch {
    std::string state = "running";  // running | exited (restart pending)
    std::string last_exit;          // how it last ended
    std::uint64_t restarts = 0;
    std::int64_t restart_at_ns = 0;
    Backoff backoff{1.0, 60.0};  // doubles per failed restart, at most 60 s; back to 1 once it runs
  };
  std::vector<EmulatorWatch> emulator_watch_;
  // The I/O thread: every loop-driven device and the pipeline (declared before the devices: it
  // outlives them).
  drivers::IoLoop io_;
  std::vector<std::unique_ptr<drivers::Driver>> devices_;
  EventLoop loop_;
  Outbox outbox_;
  std::unique_ptr<Pipeline> pipeline_;
  SessionManager* sessions_ = nullptr;        // owned by pipeline_ (a stage)
  std::vector<LatestResult> latest_params_;   // newest PARAMS per session kind (and axis, when it names one)
  std::vector<LatestResult> latest_explain_;  // newest EXPLAIN per session kind
  std::unique_ptr<SocketServer> server_;
  std::unique_ptr<plant::Publisher> mqtt_;  // [mqtt]: PARAMS, EXPLAIN, EVENTs and the device table to the broker
  SystemdNotifier notifier_;
  std::unordered_map<ClientId, Subscription> subscriptions_;
  std::vector<drivers::DeviceState> last_states_;
  int stop_fd_ = -1;
  int signal_fd_ = -1;
  std::int64_t started_ns_ = 0;
  std::int64_t last_status_ns_ = 0;
  PipelineStats last_stats_;
  RepeatLimiter dropped_log_;  // clients dropped: one line per reason per minute
};

}  // namespace guideway::daemon
