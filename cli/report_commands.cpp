// `guideway report INPUT... --out report.html`: one self-contained HTML report (inline SVG plots) of
// DBB runs, straightness traverses, Union Jack sets, run-out revolutions, profiles and explanations
// (report/report.hpp, docs/reports.md).
#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "core/atomic_file.hpp"
#include "core/utc_time.hpp"
#include "report/report.hpp"

namespace guideway::cli {

namespace {

void add_report_commands(CLI::App& app, CliContext& /*ctx*/) {
  struct Args {
    std::vector<std::string> inputs;
    std::string out;
    std::string title = "Guideway report";
    std::string wavelet = "db1";
    int level = 5;
    bool no_date = false;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "report", "Write one self-contained HTML report (plots, tables) of DBB runs, straightness traverses, Union "
                "Jack sets, run-out revolutions, profiles and explanations");
  cmd->add_option("inputs", args->inputs,
                  "input files (DBB runs, straightness, run-out, profile CSV or X3P, explain JSON) and Union Jack "
                  "directories; recognised by their format metadata or columns")
      ->required();
  cmd->add_option("-o,--out", args->out, "HTML file to write ('-': standard output)")->required();
  cmd->add_option("--title", args->title, "page title");
  cmd->add_option("--wavelet", args->wavelet, "wavelet of the profile MRA (default db1, as Mu 2012)");
  cmd->add_option("--level", args->level, "MRA levels (default 5)")->check(CLI::Range(1, 20));
  cmd->add_flag("--no-date", args->no_date, "leave the generation time out (reproducible files)");
  cmd->callback([args] {
    report::ReportOptions opt;
    opt.title = args->title;
    opt.wavelet = args->wavelet;
    opt.wavelet_level = args->level;
    if (!args->no_date) opt.subtitle = "Generated " + utc_now("%Y-%m-%d %H:%M UTC") + " by guideway report";
    std::string html;
    try {
      html = report::render_report(args->inputs, opt);
    } catch (const report::ReportError& e) {
      throw std::runtime_error(e.what());
    } catch (const std::invalid_argument& e) {  // e.g. an unknown wavelet name
      throw std::runtime_error(std::string("report: ") + e.what());
    }
    if (args->out == "-") {
      std::cout << html;
      return;
    }
    write_file_atomically(args->out, html);  // a viewer never sees half a report
    std::cerr << "report: " << args->inputs.size() << " input(s) -> " << args->out << " (" << html.size()
              << " bytes)\n";
  });
}

const CommandGroup group(&add_report_commands);

}  // namespace

}  // namespace guideway::cli
