#pragma once
// guidewayd configuration: [daemon] settings and the [[device]] tables, validated with file, line and
// key in every error. Device tables are validated by their driver factories when drivers are created.

#include <sys/types.h>

#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/instrument.hpp"
#include "core/toml_access.hpp"
#include "daemon/emulator_launcher.hpp"
#include "plant/publisher.hpp"

namespace guideway::daemon {

struct DaemonConfig {
  std::string source;  // file name, or "<embedded default>"
  std::string socket_path;
  mode_t socket_mode = 0660;
  std::string socket_group;
  std::string tcp_host;  // empty: no TCP listener
  int tcp_port = 0;
  std::string state_dir;
  std::string plugin_dir;
  std::string log_level = "info";
  double status_period_s = 1.0;
  double sample_publish_hz = 10.0;  // rate of decimated SAMPLE messages per device
  // [daemon] ring_capacity: every device's ring that gives none of its own; nullopt: each device's by the rule
  // (drivers/ring_capacity.hpp).
  std::optional<std::size_t> ring_capacity;
  std::size_t max_clients = 256;
  std::size_t reserved_clients = 8;  // of max_clients, kept for root and the daemon's own user/group
  double idle_timeout_s = 30.0;      // a connection with no complete request by then is closed; 0 = never
  std::size_t client_queue_bytes = 4 * 1024 * 1024;
  std::size_t max_request_bytes = 16 * 1024;
  // Where the threads run (daemon/cpu_placement.hpp): nullopt = every CPU the process may use but the
  // isolated ones; and their nice value (nullopt: as started).
  std::optional<std::set<int>> cpu_affinity;
  std::optional<int> nice;
  // A session on a device whose calibration has run out (or states no calibration_due) is refused
  // instead of warned about.
  bool refuse_uncalibrated = false;

  struct Device {
    std::string name;
    std::string driver;
    std::optional<std::size_t> ring_capacity;  // its own, else [daemon]'s; nullopt: the rule's
    std::shared_ptr<TableReader> table;  // the [[device]] table, for the driver factory
    Instrument instrument;               // its serial and calibration (daemon/instrument_config.hpp)
    std::vector<std::string> emulators;  // the [[emulator]]s its table refers to (launch_emulators)
  };
  std::vector<Device> devices;
  // [[processing]]: online wavelet denoising of one channel of a device (daemon/channel_denoiser.hpp).
  struct Processing {
    std::string device;
    std::string channel;
    std::string wavelet = "db4";
    int levels = 4;
    std::string threshold = "soft";  // "soft" | "hard"
    bool level_dependent = false;
    std::size_t noise_window = 1024;     // detail coefficients in the running noise estimate
    std::shared_ptr<TableReader> table;  // to name file and line when the channel turns out unknown
  };
  std::vector<Processing> processing;
  // [[session_trigger]]: a session that begins when a device's channel rises above 0.5 and ends when it
  // falls: a controller's pin (LinuxCNC's session pin through a linuxcnc-hal device; docs/linuxcnc.md).
  struct SessionTrigger {
    std::string device;     // whose channel says when
    std::string channel;
    std::string kind;       // the session it starts
    std::string on_device;  // on this device ("": the first that can run the kind)
    std::string options;    // JSON object: the session's options
    // The session ends this long after the channel falls: the instrument's last readings may reach guidewayd
    // after the controller's pin (a bus's latency; the virtual machine plays LinuxCNC's periods back late).
    double end_after_s = 3.0;
    std::shared_ptr<TableReader> table;  // to name file and line when the device or channel is unknown
  };
  std::vector<SessionTrigger> session_triggers;
  std::vector<EmulatorSpec> emulators;  // [[emulator]]: started before the devices
  std::string emulator_executable;      // default: guideway-emulate beside guidewayd, else PATH
  // Where a finished session identified from its derived files (a DBB session's runs) is analysed: "process",
  // a child `analysis_executable --analyse-session` (daemon/session_analysis.hpp; default: guidewayd itself,
  // DaemonOptions::analysis_executable), or "daemon", in the daemon's own worker thread.
  std::string session_analysis = "process";
  std::string analysis_executable;
  std::string emulator_machine;  // the virtual machine every emulator runs (absolute; "" = its compiled-in default)
  std::optional<plant::PublisherSettings> mqtt;  // [mqtt]: publish to a plant's broker (docs/plant.md)
  // [explain] memory_mb: what each session's EXPLAIN may keep in its caches (ExplainOptions::memory_mb, as
  // `guideway explain --memory-mb`); nullopt: EXPLAIN's default.
  std::optional<std::size_t> explain_memory_mb;

  std::shared_ptr<toml::table> root;  // keeps the parsed document alive for the device readers
};

DaemonConfig parse_config(std::string_view text, const std::string& file_name);
// A path a configuration file names: relative to that file's directory, as its reader means it (the
// embedded default, "<...>", has none: relative to the working directory).
std::filesystem::path config_relative_path(const std::string& config_file, const std::string& value);
// Starts the [[emulator]] processes and puts their endpoints into the device tables ("emulator:NAME").
// Throws ConfigError for an unknown NAME, std::runtime_error when an emulator does not come up.
std::vector<std::unique_ptr<EmulatorProcess>> launch_emulators(DaemonConfig& config);
DaemonConfig load_config_file(const std::string& path);
// One warning per enabled device whose calibration had run out on `on` (calibration_warning's text).
std::vector<std::string> calibration_warnings(const DaemonConfig& config, const CalendarDate& on);
DaemonConfig default_config();
std::string_view default_config_text();

}  // namespace guideway::daemon
