// `guideway-emulate micrometer`: an emulated gauge amplifier on Modbus TCP or RTU (pseudo-terminal).
// Fault injection from stdin, one command per line: "fault <name> [count]", "disconnect <ms>".
#include <signal.h>

#include <iostream>
#include <thread>

#include "simulators/emulators/emulator_command.hpp"
#include "simulators/emulators/modbus_emulator.hpp"

namespace guideway::emulators {
namespace {

struct MicrometerArgs {
  std::string tcp;
  bool rtu = false;
  int baud = 19200;
  std::string parity = "E";
  int unit_id = 1;
  double rpm = 60.0;
  double eccentricity_um = 2.0;
};

int run_micrometer(const MicrometerArgs& a) {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);

  MicrometerEmulator::Options options;
  options.unit_id = a.unit_id;
  options.source = runout_source(a.rpm, a.eccentricity_um * 1e-6);
  MicrometerEmulator emulator(options);
  std::string error;
  if (a.rtu) {
    const std::string path = emulator.start_rtu(a.baud, a.parity[0], 8, 1, error);
    if (path.empty()) {
      std::cerr << "guideway-emulate micrometer: " << error << "\n";
      return 1;
    }
    std::cout << path << std::endl;
  } else {
    const auto colon = a.tcp.rfind(':');
    if (colon == std::string::npos) {
      std::cerr << "guideway-emulate micrometer: --tcp expects HOST:PORT\n";
      return 2;
    }
    const int port = emulator.start_tcp(a.tcp.substr(0, colon), std::atoi(a.tcp.c_str() + colon + 1), error);
    if (port < 0) {
      std::cerr << "guideway-emulate micrometer: " << error << "\n";
      return 1;
    }
    std::cout << a.tcp.substr(0, colon) << ":" << port << std::endl;
  }
  std::thread control([&emulator] {
    std::string line, message;
    while (std::getline(std::cin, line)) {
      if (line.empty()) continue;
      apply_micrometer_command(emulator, line, message);
      std::cerr << message << std::endl;
    }
  });
  control.detach();  // blocked in getline; the process exits on the signal
  int sig = 0;
  sigwait(&set, &sig);
  emulator.stop();
  return 0;
}

void add_micrometer(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<MicrometerArgs>();
  CLI::App* sub = app.add_subcommand("micrometer", "inductance micrometer gauge amplifier on Modbus TCP or RTU");
  auto* tcp = sub->add_option("--tcp", args->tcp, "serve Modbus TCP on HOST:PORT (port 0: any free port; printed)");
  auto* rtu = sub->add_flag("--rtu", args->rtu, "serve Modbus RTU on a pseudo-terminal (its path is printed)");
  tcp->excludes(rtu);
  sub->add_option("--baud", args->baud, "RTU baud rate")->capture_default_str();
  sub->add_option("--parity", args->parity, "RTU parity N, E or O")->check(CLI::IsMember({"N", "E", "O"}));
  sub->add_option("--unit-id", args->unit_id, "Modbus unit (slave) id")->capture_default_str();
  sub->add_option("--rpm", args->rpm, "spindle speed of the run-out revolution")->capture_default_str();
  sub->add_option("--eccentricity-um", args->eccentricity_um, "spindle eccentricity seen by the probe")
      ->capture_default_str();
  sub->callback([args, sub, &exit_code] {
    if (args->tcp.empty() && !args->rtu) throw CLI::RequiredError("--tcp HOST:PORT or --rtu");
    (void)sub;
    exit_code = run_micrometer(*args);
  });
}

const EmulatorCommand registered{add_micrometer};

}  // namespace
}  // namespace guideway::emulators
