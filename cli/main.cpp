// guideway: the command-line client of guidewayd and the offline analysis tool.
#include <csignal>
#include <iostream>

#include "cli/commands.hpp"
#include "core/input_file.hpp"
#include "core/memory_policy.hpp"

namespace guideway::cli {

CommandGroup::CommandGroup(AddCommandsFn fn) { all().push_back(fn); }

std::vector<AddCommandsFn>& CommandGroup::all() {
  static std::vector<AddCommandsFn> groups;
  return groups;
}

CLI::App* add_commands(CLI::App& parent, CliContext& ctx, const std::vector<Command>& table) {
  CLI::App* last = nullptr;
  for (const Command& c : table) {
    last = parent.add_subcommand(c.name, c.description);
    c.define(*last, ctx);
  }
  return last;
}

CLI::App* shared_subcommand(CLI::App& app, const std::string& name, const std::string& description) {
  try {
    return app.get_subcommand(name);
  } catch (const CLI::OptionNotFound&) {
    auto* p = app.add_subcommand(name, description);
    p->require_subcommand(1);
    return p;
  }
}

namespace {

// Every required option the command line lacks, named at once and in one form (CLI11 names the first
// only, in its own words): "" when it lacks none.
std::string all_missing(const CLI::App& app) {
  const CLI::App* cmd = &app;
  std::string path = "guideway";
  while (!cmd->get_subcommands().empty()) {
    cmd = cmd->get_subcommands().front();
    path += " " + cmd->get_name();
  }
  std::string missing;
  int count = 0;
  for (const CLI::Option* o : cmd->get_options()) {
    if (!o->get_required() || o->count() > 0) continue;
    missing += (count++ ? ", " : "") + o->get_name();
  }
  if (count == 0) return {};
  const std::string help = path.substr(9) + " --help says what ";
  return path + ": missing " + missing +
         (count == 1 ? " (required; " + help + "it is)" : " (each is required; " + help + "they are)");
}

}  // namespace

}  // namespace guideway::cli

int main(int argc, char** argv) {
  guideway::keep_freed_memory();
  // Past `ulimit -f` a write fails with EFBIG and is reported like a full disk, instead of the signal
  // killing the command half way through writing a set of files.
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"guideway: client of guidewayd and offline analysis of metrology recordings"};
  app.require_subcommand(1);
  guideway::cli::CliContext ctx;
  app.add_option("-s,--socket", ctx.socket,
                 "daemon address: a Unix socket path or tcp:HOST:PORT (default: $GUIDEWAY_SOCKET, the per-user "
                 "socket, then /run/guideway/guideway.sock)");
  app.set_version_flag("-V,--version", "guideway " GUIDEWAY_VERSION);
  // Every file a command reads: at most so many bytes and rows (core/input_file.hpp, docs/formats.md "Limits").
  app.add_option_function<double>(
         "--max-input-mb",
         [](double mb) {
           guideway::InputLimits l = guideway::input_limits();
           l.max_bytes = static_cast<std::uint64_t>(mb * 1e6);
           guideway::set_input_limits(l);
         },
         "largest input file read, MB (default 2000: 2 GB)")
      ->check(CLI::Range(0.001, 1e6));
  app.add_option_function<double>(
         "--max-input-rows",
         [](double rows) {
           guideway::InputLimits l = guideway::input_limits();
           l.max_rows = static_cast<std::uint64_t>(rows);
           guideway::set_input_limits(l);
         },
         "most data rows read from one table (default 50000000)")
      ->check(CLI::Range(1.0, 1e12));
  // `guideway status --socket P` as well as `guideway --socket P status`: a subcommand hands the
  // options it does not know to the app (subcommands inherit this setting when they are added).
  app.fallthrough();
  for (auto add : guideway::cli::CommandGroup::all()) add(app, ctx);
  try {
    app.parse(argc, argv);
  } catch (const CLI::RequiredError& e) {
    if (const std::string missing = guideway::cli::all_missing(app); !missing.empty()) {
      std::cerr << missing << "\n";
      return e.get_exit_code();
    }
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::cerr << "guideway: " << e.what() << "\n";
    return 1;
  }
  return ctx.exit_code;
}
