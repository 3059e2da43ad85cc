#pragma once
// Each group of `guideway` subcommands registers itself on the CLI11 app. A command's callback
// prints its result and sets ctx.exit_code; it throws std::runtime_error for a user-facing error
// (main prints "guideway: <message>" and exits 1).

#include <string>

#include <CLI/CLI.hpp>

namespace guideway::cli {

struct CliContext {
  int exit_code = 0;
  std::string socket;  // --socket: address of the daemon (path or tcp:HOST:PORT); empty = defaults
};

void add_daemon_commands(CLI::App& app, CliContext& ctx);  // version, status, watch

}  // namespace guideway::cli
