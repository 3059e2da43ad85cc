#pragma once
// Each group of `guideway` subcommands registers itself on the CLI11 app through a static
// CommandGroup in its own source file (compiled into the `guideway` executable, see
// cli/CMakeLists.txt). A command's callback prints its result and may set ctx.exit_code; it throws
// std::runtime_error for a user-facing error (main prints "guideway: <message>" and exits 1).

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace guideway::cli {

struct CliContext {
  int exit_code = 0;
  std::string socket;  // --socket: address of the daemon (path or tcp:HOST:PORT); empty = defaults
};

using AddCommandsFn = void (*)(CLI::App& app, CliContext& ctx);

// Registers a group at static-initialisation time: `static const CommandGroup group(&add_x_commands);`
struct CommandGroup {
  explicit CommandGroup(AddCommandsFn fn);
  static std::vector<AddCommandsFn>& all();
};

}  // namespace guideway::cli
