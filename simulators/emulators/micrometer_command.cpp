// `guideway-emulate micrometer`: an emulated gauge amplifier on Modbus TCP or RTU (pseudo-terminal).
// Prints "endpoint: tcp:HOST:PORT" or "endpoint: pty:PATH" once it serves.
// Fault injection from stdin, one command per line: "fault <name> [count]", "disconnect <ms>".
#include <signal.h>

#include <iostream>
#include <thread>

#include "simulators/emulators/emulator_command.hpp"
#include "simulators/emulators/micrometer_machine_source.hpp"
#include "simulators/emulators/modbus_emulator.hpp"

namespace guideway::simulators::emulators {
namespace {

struct MicrometerArgs {
  std::string tcp;
  bool rtu = false;
  int baud = 19200;
  std::string parity = "E";
  int unit_id = 1;
  std::string machine_file;
  double rpm = 60.0;               // the runout session's default
  double probe_radius_mm = 500.0;  // rim of a 1000 mm plate: the runout session's default plate_diameter_mm
  std::size_t samples_per_rev = 360;
  double ring_rate_hz = 10000.0;  // the sample ring (docs/protocols.md, "Buffered acquisition")
  std::uint32_t ring_samples = 4096;
  std::uint32_t ring_counter_start = 0;
};

int run_micrometer(const MicrometerArgs& a) {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  signal(SIGPIPE, SIG_IGN);  // a reader of our stdout/stderr that went away must not kill the emulator

  MicrometerEmulator::Options options;
  options.unit_id = a.unit_id;
  if (a.ring_rate_hz > 0.0) {
    drivers::modbus::SampleRingMap ring;  // counter at 100-101, slots of int32 + status from 200
    ring.sample_rate_hz = a.ring_rate_hz;
    ring.ring_samples = a.ring_samples;
    if (const std::string why = ring.validate(); !why.empty()) {
      std::cerr << "guideway-emulate micrometer: sample ring: " << why << "\n";
      return 2;
    }
    options.ring = ring;
    options.ring_counter_start = a.ring_counter_start;
  }
  std::string error;
  try {
    const machine::Machine machine(a.machine_file.empty() ? machine::default_machine_config()
                                                          : machine::load_machine_config(a.machine_file));
    machine::RunoutSpec spec;
    spec.rpm = a.rpm;
    spec.probe_radius_m = a.probe_radius_mm * 1e-3;
    spec.samples_per_rev = a.samples_per_rev;
    options.source = runout_motion_source(make_runout_motion(machine, spec));
  } catch (const std::exception& e) {
    std::cerr << "guideway-emulate micrometer: " << e.what() << "\n";
    return 2;
  }
  MicrometerEmulator emulator(options);
  if (a.rtu) {
    const std::string path = emulator.start_rtu(a.baud, a.parity[0], 8, 1, error);
    if (path.empty()) {
      std::cerr << "guideway-emulate micrometer: " << error << "\n";
      return 1;
    }
    std::cout << "endpoint: pty:" << path << std::endl;  // the daemon's emulator launcher reads this line
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
    std::cout << "endpoint: tcp:" << a.tcp.substr(0, colon) << ":" << port << std::endl;
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
  sub->add_option("--machine", args->machine_file, "virtual machine tool file (default: config/machine-example.toml, compiled in)");
  sub->add_option("--rpm", args->rpm,
                  "spindle speed of the run-out revolutions (the machine file's speed_ramp drifts it)")
      ->capture_default_str();
  sub->add_option("--probe-radius-mm", args->probe_radius_mm, "probe radius on the thrust plate")
      ->capture_default_str();
  sub->add_option("--samples-per-rev", args->samples_per_rev, "model samples per revolution")->capture_default_str();
  sub->add_option("--ring-rate-hz", args->ring_rate_hz,
                  "sample rate of the sample ring (counter at input/holding registers 100-101, int32 + status "
                  "slots from 200; 0: no ring)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  sub->add_option("--ring-samples", args->ring_samples, "slots in the sample ring")
      ->capture_default_str()
      ->check(CLI::Range(1, 21778));
  sub->add_option("--ring-counter-start", args->ring_counter_start,
                  "the counter's first value (e.g. 4294967000 to see it wrap)")
      ->capture_default_str();
  sub->callback([args, sub, &exit_code] {
    if (args->tcp.empty() && !args->rtu) throw CLI::RequiredError("--tcp HOST:PORT or --rtu");
    (void)sub;
    exit_code = run_micrometer(*args);
  });
}

const EmulatorCommand registered{add_micrometer};

}  // namespace
}  // namespace guideway::simulators::emulators
