// The `guideway-emulate <instrument>` subcommands (emulator_command.hpp), each registered from its instrument's file.
#include "simulators/emulators/emulator_command.hpp"

namespace guideway::simulators::emulators {

EmulatorCommand::EmulatorCommand(AddEmulatorFn fn) { all().push_back(fn); }

std::vector<AddEmulatorFn>& EmulatorCommand::all() {
  static std::vector<AddEmulatorFn> groups;
  return groups;
}

}  // namespace guideway::simulators::emulators
