#include "simulators/emulators/emulator_command.hpp"

namespace guideway::emulators {

EmulatorCommand::EmulatorCommand(AddEmulatorFn fn) { all().push_back(fn); }

std::vector<AddEmulatorFn>& EmulatorCommand::all() {
  static std::vector<AddEmulatorFn> groups;
  return groups;
}

}  // namespace guideway::emulators
