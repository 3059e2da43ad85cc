// guideway-linuxcnc-bridge: LinuxCNC's servo periods (halsampler) served to Guideway (drivers/linuxcnc/
// bridge.hpp). Started by LinuxCNC's HAL (linuxcnc/guideway-bridge.hal: `loadusr guideway-linuxcnc-bridge
// ...`); docs/linuxcnc.md.
#include <iostream>

#include <CLI/CLI.hpp>

#include "drivers/linuxcnc/bridge.hpp"
#include "drivers/linuxcnc/hal_stream.hpp"

int main(int argc, char** argv) {
  namespace lc = guideway::drivers::linuxcnc;
  lc::BridgeOptions o;
  std::string columns(lc::default_columns);
  int channel = 0;
  std::string source;
  std::string mode = "0666";
  CLI::App app{
      "guideway-linuxcnc-bridge: serves LinuxCNC's servo periods (sampler + halsampler -t) to Guideway on a Unix "
      "socket (docs/linuxcnc.md)"};
  app.add_option("--socket", o.socket_path, "the Unix socket clients connect to")->capture_default_str();
  app.add_option("--socket-mode", mode, "its permissions (octal)")->capture_default_str();
  app.add_option("--channel", channel, "the sampler FIFO halsampler reads (halsampler -c)")->capture_default_str();
  app.add_option("--period-ns", o.period_ns, "LinuxCNC's servo period ([EMCMOT]SERVO_PERIOD)")
      ->check(CLI::Range(std::int64_t{1000}, std::int64_t{1000000000}))
      ->capture_default_str();
  app.add_option("--columns", columns, "the name of each sampled pin, in the sampler's order")->capture_default_str();
  app.add_option("--source", source,
                 "a program to read instead of halsampler (its stdout in halsampler -t's form; for tests)");
  app.add_option("--queue-mib", o.client_queue_bytes, "what a slow client may fall behind before periods are "
                                                      "dropped for it (MiB)")
      ->transform([](std::string s) { return std::to_string(std::stoull(s) << 20); });
  CLI11_PARSE(app, argc, argv);
  try {
    o.columns = lc::parse_column_list(columns);
    o.socket_mode = static_cast<unsigned>(std::stoul(mode, nullptr, 8));
  } catch (const std::exception& e) {
    std::cerr << "guideway-linuxcnc-bridge: " << e.what() << "\n";
    return 2;
  }
  if (!source.empty()) {
    o.source_command = {"/bin/sh", "-c", source};
  } else {
    o.source_command = {"halsampler", "-t", "-c", std::to_string(channel)};
  }
  return lc::run_bridge(o, std::cerr);
}
