#pragma once
// Each emulated instrument registers a `guideway-emulate <instrument>` subcommand through a static
// EmulatorCommand in its own source file. Because the sources live in a static library, the
// executable references every group's anchor (see emulate_main.cpp) so the linker keeps them.

#include <vector>

#include <CLI/CLI.hpp>

namespace guideway::emulators {

using AddEmulatorFn = void (*)(CLI::App& app, int& exit_code);

struct EmulatorCommand {
  explicit EmulatorCommand(AddEmulatorFn fn);
  static std::vector<AddEmulatorFn>& all();
};

}  // namespace guideway::emulators
