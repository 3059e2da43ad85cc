#pragma once
// Each group of `guideway` subcommands registers itself on the CLI11 app through a static
// CommandGroup in its own source file (compiled into the `guideway` executable, see
// cli/CMakeLists.txt). A group is a table of commands: each a name, its help, the struct of its options
// (whose add() declares them on the subcommand) and a handler run with them after parsing. A handler
// prints its result and may set ctx.exit_code; it throws std::runtime_error for a user-facing error
// (main prints "guideway: <message>" and exits 1).

#include <functional>
#include <memory>
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

// One subcommand of a table: made by command<Options>(); `define` adds its options to the subcommand and
// sets its handler.
struct Command {
  std::string name;
  std::string description;
  std::function<void(CLI::App& cmd, CliContext& ctx)> define;
};

// The row of a command whose options are the fields of `Options` (declared by `void add(CLI::App&)`)
// and whose handler is `run`.
template <class Options>
Command command(std::string name, std::string description, void (*run)(const Options&, CliContext&)) {
  return {std::move(name), std::move(description), [run](CLI::App& cmd, CliContext& ctx) {
            auto options = std::make_shared<Options>();
            options->add(cmd);
            cmd.callback([options, run, &ctx] { run(*options, ctx); });
          }};
}

// A command without options of its own.
struct NoOptions {
  void add(CLI::App& /*cmd*/) {}
};

// Adds every command of `table` to `parent` (the app, or a parent subcommand); returns the last added.
CLI::App* add_commands(CLI::App& parent, CliContext& ctx, const std::vector<Command>& table);

// A parent subcommand several groups add children to (`identify`, `simulate`): created by the first
// group that asks, whatever the static-initialisation order, and returned to the others.
CLI::App* shared_subcommand(CLI::App& app, const std::string& name, const std::string& description);
// `guideway identify`, the parent of every offline identification.
inline CLI::App* identify_command(CLI::App& app) {
  return shared_subcommand(app, "identify", "identify model parameters from a recording or measurement file");
}

}  // namespace guideway::cli
