// `guideway-emulate profilometer`: an emulated PGI 1240-style profilometer streaming traverses on TCP.
// Prints "endpoint: tcp:HOST:PORT" once it serves.
// Fault injection from stdin, one command per line: "fault <name> [count]", "disconnect <ms>", "stall <ms>".
#include <signal.h>

#include <iostream>
#include <thread>

#include "simulators/emulators/emulator_command.hpp"
#include "simulators/emulators/profilometer_emulator.hpp"
#include "simulators/emulators/profilometer_machine_source.hpp"

namespace guideway::simulators::emulators {
namespace {

struct ProfilometerArgs {
  std::string host = "127.0.0.1";
  int port = 4001;
  double points_per_s = 5000.0;
  std::string machine_file;
  bool synthetic = false;
  std::size_t points = 1000;
  double spacing_um = 2.0;
};

int run_profilometer(const ProfilometerArgs& a) {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  signal(SIGPIPE, SIG_IGN);  // a reader of our stdout/stderr that went away must not kill the emulator
  ProfilometerEmulator::Options options;
  options.points_per_s = a.points_per_s;
  if (a.synthetic) {
    options.source = faced_profile_source(a.points, a.spacing_um * 1e-6);
  } else {
    try {
      auto machine = std::make_shared<const machine::Machine>(
          a.machine_file.empty() ? machine::default_machine_config() : machine::load_machine_config(a.machine_file));
      options.source = facing_profile_source(machine, demo_facing_spec());
    } catch (const std::exception& e) {
      std::cerr << "guideway-emulate profilometer: " << e.what() << "\n";
      return 2;
    }
  }
  ProfilometerEmulator emulator(options);
  std::string error;
  const int port = emulator.start(a.host, a.port, error);
  if (port < 0) {
    std::cerr << "guideway-emulate profilometer: " << error << "\n";
    return 1;
  }
  std::cout << "endpoint: tcp:" << a.host << ":" << port << std::endl;  // read by the daemon's emulator launcher
  std::thread control([&emulator] {
    std::string line, message;
    while (std::getline(std::cin, line)) {
      if (line.empty()) continue;
      apply_profilometer_command(emulator, line, message);
      std::cerr << message << std::endl;
    }
  });
  control.detach();
  int sig = 0;
  sigwait(&set, &sig);
  emulator.stop();
  return 0;
}

void add_profilometer(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<ProfilometerArgs>();
  CLI::App* sub = app.add_subcommand("profilometer", "PGI 1240-style profilometer streaming profiles on TCP");
  sub->add_option("--host", args->host, "IPv4 address to listen on")->capture_default_str();
  sub->add_option("--port", args->port, "TCP port (0: any free port; the address is printed)")->capture_default_str();
  sub->add_option("--points-per-s", args->points_per_s, "stream rate")->capture_default_str();
  sub->add_option("--machine", args->machine_file, "virtual machine tool file (default: config/machine-example.toml, compiled in)");
  sub->add_flag("--synthetic", args->synthetic,
                "stream synthetic feed-mark profiles instead of the machine's faced profile");
  sub->add_option("--points", args->points, "--synthetic: points per traverse")->capture_default_str();
  sub->add_option("--spacing-um", args->spacing_um, "--synthetic: point spacing")->capture_default_str();
  sub->callback([args, &exit_code] { exit_code = run_profilometer(*args); });
}

const EmulatorCommand registered{add_profilometer};

}  // namespace
}  // namespace guideway::simulators::emulators
