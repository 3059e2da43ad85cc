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

// A parent subcommand several groups add children to (`identify`, `simulate`): created by the first
// group that asks, whatever the static-initialisation order, and returned to the others.
CLI::App* shared_subcommand(CLI::App& app, const std::string& name, const std::string& description);
// `guideway identify`, the parent of every offline identification.
inline CLI::App* identify_command(CLI::App& app) {
  return shared_subcommand(app, "identify", "identify model parameters from a recording or measurement file");
}

}  // namespace guideway::cli
