#pragma once
// Each emulated instrument registers a `guideway-emulate <instrument>` subcommand through a static
// EmulatorCommand in its own source file (guideway_emulators is an OBJECT library, so the linker
// keeps every registration object).

#include <vector>

#include <CLI/CLI.hpp>

namespace guideway::simulators::emulators {

using AddEmulatorFn = void (*)(CLI::App& app, int& exit_code);

struct EmulatorCommand {
  explicit EmulatorCommand(AddEmulatorFn fn);
  static std::vector<AddEmulatorFn>& all();
};

}  // namespace guideway::simulators::emulators
