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
#include "cli/progress.hpp"
#include "core/atomic_file.hpp"
#include "core/utc_time.hpp"
#include "report/report.hpp"

namespace guideway::cli {

namespace {

struct ReportArgs {
  std::vector<std::string> inputs;
  std::string out;
  std::string title = "Guideway report";
  std::string wavelet = "db1";
  int level = 5;
  bool no_date = false, quiet = false;
  void add(CLI::App& cmd) {
    cmd.add_option("inputs", inputs,
                   "input files (DBB runs, straightness, run-out, profile CSV or X3P, explain JSON) and Union Jack "
                   "directories; recognised by their format metadata or columns")
        ->required();
    cmd.add_option("-o,--out", out, "HTML file to write ('-': standard output)")->required();
    cmd.add_option("--title", title, "page title");
    cmd.add_option("--wavelet", wavelet, "wavelet of the profile MRA (default db1, as Mu 2012)");
    cmd.add_option("--level", level, "MRA levels (default 5)")->check(CLI::Range(1, 20));
    cmd.add_flag("--no-date", no_date, "leave the generation time out (reproducible files)");
    cmd.add_flag("--quiet", quiet, "no progress lines on standard error");
  }
};

void run_report(const ReportArgs& a, CliContext& /*ctx*/) {
  report::ReportOptions opt;
  opt.title = a.title;
  opt.wavelet = a.wavelet;
  opt.wavelet_level = a.level;
  if (!a.no_date) opt.subtitle = "Generated " + utc_now("%Y-%m-%d %H:%M UTC") + " by guideway report";
  std::string html;
  try {
    Progress progress("report", a.quiet);
    progress.doing("reading and plotting " + std::to_string(a.inputs.size()) + " input(s)");
    html = report::render_report(a.inputs, opt);
  } catch (const report::ReportError& e) {
    throw std::runtime_error(e.what());
  } catch (const std::invalid_argument& e) {  // e.g. an unknown wavelet name
    throw std::runtime_error(std::string("report: ") + e.what());
  }
  if (a.out == "-") {
    std::cout << html;
    return;
  }
  write_file_atomically(a.out, html);  // a viewer never sees half a report
  std::cerr << "report: " << a.inputs.size() << " input(s) -> " << a.out << " (" << html.size() << " bytes)\n";
}

void add_report_commands(CLI::App& app, CliContext& ctx) {
  add_commands(app, ctx,
               {command("report",
                        "Write one self-contained HTML report (plots, tables) of DBB runs, straightness traverses, "
                        "Union Jack sets, run-out revolutions, profiles and explanations",
                        &run_report)});
}

const CommandGroup group(&add_report_commands);

}  // namespace

}  // namespace guideway::cli
