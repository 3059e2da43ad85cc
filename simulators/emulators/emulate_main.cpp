// guideway-emulate: device emulators for Guideway, one instrument per process.
#include <iostream>

#include "simulators/emulators/emulator_command.hpp"

int main(int argc, char** argv) {
  CLI::App app{"guideway-emulate: emulated instruments driven by the virtual machine tool, on their real transports"};
  app.require_subcommand(1);
  int exit_code = 0;
  for (auto add : guideway::simulators::emulators::EmulatorCommand::all()) add(app, exit_code);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "guideway-emulate: " << e.what() << "\n";
    return 1;
  }
  return exit_code;
}
