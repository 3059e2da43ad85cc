// guidewayd: the Guideway acquisition daemon.
#include <signal.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <iostream>

#include <CLI/CLI.hpp>

#include "core/memory_policy.hpp"
#include "core/runtime_paths.hpp"
#include "core/utc_time.hpp"
#include "daemon/config.hpp"
#include "daemon/cpu_placement.hpp"
#include "daemon/daemon.hpp"
#include "daemon/logging.hpp"
#include "daemon/reports/session_report.hpp"
#include "daemon/session_analysis.hpp"
#include "drivers/builtin.hpp"
#include "sessions/session_kinds.hpp"

using namespace guideway;

int main(int argc, char** argv) {
  CLI::App app{"guidewayd: real-time metrology acquisition daemon for machine tools"};
  std::string config_path;
  std::string socket_override;
  std::string log_level;
  bool check_only = false;
  bool print_default = false;
  bool list_drivers = false;
  bool show_version = false;
  app.add_option("-c,--config", config_path,
                 "TOML configuration file (default: the embedded default, emulated instruments)");
  app.add_option("-s,--socket", socket_override, "Unix socket path (overrides [daemon] socket)");
  // Checked: spdlog reads an unknown level name as "off", which would silence the daemon.
  app.add_option("-l,--log-level", log_level, "trace, debug, info, warn, error (overrides [daemon] log_level)")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}));
  std::string emulator_machine;
  app.add_option("--emulator-machine", emulator_machine,
                 "the virtual machine tool file every emulator runs (overrides [daemon] emulator_machine)")
      ->check(CLI::ExistingFile);
  app.add_flag("--check-config", check_only, "validate the configuration (and create the drivers) and exit");
  app.add_flag("--print-default-config", print_default, "print the embedded default configuration and exit");
  app.add_flag("--list-drivers", list_drivers, "list the available drivers (built-in and plugins) and exit");
  app.add_flag("-V,--version", show_version, "print the version and exit");
  bool analyse_session = false;
  app.add_flag("--analyse-session", analyse_session,
               "(what guidewayd starts itself) analyse one finished session: requests on stdin, answers on stdout "
               "(daemon/session_analysis.hpp)");
  CLI11_PARSE(app, argc, argv);

  if (analyse_session) {
    keep_freed_memory();
    sessions::SessionRegistry sessions;
    sessions::register_builtin_sessions(sessions);
    return daemon::run_session_analysis(std::cin, std::cout, sessions, daemon::render_session_report);
  }

  return_freed_memory();
  if (show_version) {
    std::cout << "guidewayd " << GUIDEWAY_VERSION << "\n";
    return 0;
  }
  if (print_default) {
    std::cout << daemon::default_config_text();
    return 0;
  }

  // Block the signals before any thread starts, so only the event loop's signalfd sees them.
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  signal(SIGPIPE, SIG_IGN);
  // A file-size limit (ulimit -f) must make a write fail with EFBIG, reported like a full disk, not kill
  // the daemon with every device and emulator (SIGXFSZ's default action).
  signal(SIGXFSZ, SIG_IGN);

  daemon::DaemonConfig config;
  try {
    config = config_path.empty() ? daemon::default_config() : daemon::load_config_file(config_path);
  } catch (const ConfigError& e) {
    std::cerr << "guidewayd: configuration error: " << e.what() << "\n";
    return 2;
  }
  if (!socket_override.empty()) {
    if (const std::string problem = socket_path_problem(socket_override); !problem.empty()) {
      std::cerr << "guidewayd: --socket " << socket_override << ": " << problem << "\n";
      return 2;
    }
    config.socket_path = socket_override;
  }
  if (!log_level.empty()) config.log_level = log_level;
  if (!emulator_machine.empty())
    config.emulator_machine = std::filesystem::absolute(emulator_machine).lexically_normal().string();

  std::shared_ptr<spdlog::logger> log;
  try {
    log = daemon::make_logger(config.log_level);
  } catch (const std::exception& e) {
    std::cerr << "guidewayd: " << e.what() << "\n";
    return 2;
  }

  drivers::DriverRegistry registry;
  drivers::register_builtin_drivers(registry);
  for (const std::string& err : registry.load_plugins(config.plugin_dir)) log->warn("plugin: {}", err);
  if (list_drivers) {
    for (const auto& [name, description] : registry.list()) std::cout << name << "\t" << description << "\n";
    return 0;
  }

  try {
    if (check_only) {
      // The emulators (started to resolve "emulator:" addresses) get a private runtime directory:
      // in the socket's they would replace a running daemon's endpoints.
      char scratch[] = "/tmp/guidewayd-check-XXXXXX";
      if (mkdtemp(scratch) == nullptr) throw std::runtime_error(std::string("mkdtemp: ") + std::strerror(errno));
      struct RemoveScratch {
        std::string dir;
        ~RemoveScratch() {
          std::error_code ec;
          std::filesystem::remove_all(dir, ec);
        }
      } remove_scratch{scratch};
      config.socket_path = std::string(scratch) + "/guideway.sock";
      std::vector<std::string> device_warnings;  // what a device says of its own table (an old key name)
      {
        const auto emulators = daemon::launch_emulators(config);
        const auto devices = daemon::create_devices(config, registry);
        (void)daemon::processing_steps(config, devices);
        for (const auto& d : devices)
          for (const auto& e : d->take_events())
            if (e.warning) device_warnings.push_back("device " + d->name() + ": " + e.reason);
      }
      std::cout << config.source << ": OK (" << config.devices.size() << " device(s))\n";
      for (const std::string& w : device_warnings) std::cout << "warning: " << w << "\n";
      // Not errors: the instruments still measure (unless refuse_uncalibrated refuses their sessions).
      for (const std::string& w : daemon::calibration_warnings(config, utc_today()))
        std::cout << "warning: " << w << "\n";
      return 0;
    }
    // Before any thread or emulator starts: they all inherit the placement.
    const daemon::PlacementResult placement = daemon::apply_placement({config.cpu_affinity, config.nice});
    log->info("threads on CPU {}{}{}", daemon::format_cpu_list(placement.cpus),
              placement.isolated.empty() ? "" : " (isolated: " + daemon::format_cpu_list(placement.isolated) + ")",
              config.nice ? ", nice " + std::to_string(*config.nice) : "");
    for (const std::string& w : placement.warnings) log->warn("{}", w);
    sessions::SessionRegistry sessions;
    sessions::register_builtin_sessions(sessions);
    // A finished session's analysis in a process of its own: this very program (config's session_analysis).
    std::error_code ec;
    std::string self = std::filesystem::read_symlink("/proc/self/exe", ec).string();
    if (ec || self.empty()) self = "/proc/self/exe";
    daemon::Daemon d(std::move(config), registry, sessions, log,
                     {.handle_signals = true, .session_report = daemon::render_session_report,
                      .analysis_executable = self});
    return d.run();
  } catch (const ConfigError& e) {
    log->error("configuration error: {}", e.what());
    return 2;
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
}
