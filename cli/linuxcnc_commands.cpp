// `guideway linuxcnc offsets DIR`: what a per-joint table cannot hold (the squareness of errors.csv, the
// straightness of straightness.csv) as LinuxCNC's external offsets through HAL: DIR/guideway-offsets.hal and
// the INI lines it needs, DIR/linuxcnc-offsets.ini (formats/linuxcnc_offsets; docs/linuxcnc.md).
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>

#include "cli/commands.hpp"
#include "core/atomic_file.hpp"
#include "core/csv_table.hpp"
#include "formats/compensation_files.hpp"
#include "formats/linuxcnc_offsets.hpp"

namespace guideway::cli {

namespace {

namespace fs = std::filesystem;

struct OffsetsArgs {
  std::string dir;
  double travel_mm = 1000.0;
  std::vector<std::string> leave_out;
  double ratio = 0.1;
  void add(CLI::App& cmd) {
    cmd.add_option("dir", dir, "the directory `guideway compensate dbb --out-dir` wrote")->required();
    cmd.add_option("--travel-mm", travel_mm,
                   "the skew is written out to +/- this position (LinuxCNC's lookup holds its end values beyond)")
        ->check(CLI::Range(1.0, 100000.0))
        ->capture_default_str();
    cmd.add_option("--leave-out", leave_out, "squareness and/or straightness: not corrected")
        ->check(CLI::IsMember({"squareness", "straightness"}));
    cmd.add_option("--offset-av-ratio", ratio,
                   "[AXIS_L]OFFSET_AV_RATIO: the part of the axis' velocity and acceleration kept for the offsets")
        ->check(CLI::Range(0.01, 0.9))
        ->capture_default_str();
  }
};

bool left_out(const OffsetsArgs& a, const std::string& what) {
  return std::find(a.leave_out.begin(), a.leave_out.end(), what) != a.leave_out.end();
}

// errors.csv's squareness of each plane (urad), only those written as significant.
std::map<std::string, double> significant_squareness(const fs::path& errors, std::vector<std::string>& said) {
  const CsvTable t = read_csv_table(errors.string());
  std::map<std::string, double> out;
  for (const char* plane : {"xy", "xz", "yz"}) {
    const std::string key = std::string("squareness_") + plane + "_urad";
    const auto q = t.optional_metadata_number(key);
    if (!q) continue;
    auto sig = t.metadata.find(std::string("squareness_") + plane + "_significant");
    if (sig == t.metadata.end()) sig = t.metadata.find("squareness_significant");
    if (sig != t.metadata.end() && sig->second != "true") {
      said.push_back(std::string("squareness ") + plane + " " + t.metadata.at(key) +
                     " urad: not significant in errors.csv, left out");
      continue;
    }
    out[plane] = *q * 1e-6;
  }
  return out;
}

void run_offsets(const OffsetsArgs& a, CliContext& /*ctx*/) {
  const fs::path dir(a.dir);
  const fs::path errors = dir / "errors.csv", straightness = dir / "straightness.csv";
  if (!fs::is_regular_file(errors))
    throw std::runtime_error(errors.string() + ": no such file (give the directory guideway compensate dbb wrote)");
  std::vector<std::string> said;
  std::map<std::string, double> skew;
  std::vector<formats::CrossCorrectionRow> cross;
  try {
    if (!left_out(a, "squareness")) skew = significant_squareness(errors, said);
    if (!left_out(a, "straightness")) {
      if (fs::is_regular_file(straightness)) {
        cross = formats::read_straightness_csv(straightness.string());
      } else {
        said.push_back("no straightness.csv in " + dir.string() +
                       (fs::exists(dir / "straightness.csv.do-not-load") ? " (refused: straightness.csv.do-not-load)"
                                                                          : " (no straightness was significant)"));
      }
    }
  } catch (const CsvError& e) {
    throw std::runtime_error(e.what());
  } catch (const formats::CompensationFileError& e) {
    throw std::runtime_error(e.what());
  }
  for (const auto& s : said) std::cout << s << "\n";
  std::vector<formats::OffsetCurve> curves;
  try {
    curves = formats::linuxcnc_offset_curves(skew, cross, a.travel_mm);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(std::string(e.what()) + ": nothing for LinuxCNC's external offsets");
  }
  std::vector<std::string> head = {
      "Guideway: the squareness and straightness of " + fs::absolute(dir).string() + " as LinuxCNC's external",
      "offsets (docs/linuxcnc.md). Written by guideway linuxcnc offsets; add linuxcnc-offsets.ini's lines to the INI."};
  for (const auto& [plane, q] : skew)
    head.push_back("squareness " + plane + " " + std::to_string(q * 1e6) + " urad: " + plane.substr(0, 1) + " -= q " +
                   plane.substr(1, 1));
  if (!cross.empty()) head.push_back("straightness.csv: " + std::to_string(cross.size()) + " rows");
  // The two are one correction: both written, or neither.
  write_file_set_atomically(
      dir.string(),
      {{"guideway-offsets.hal", formats::format_linuxcnc_offsets_hal(curves, head)},
       {"linuxcnc-offsets.ini", formats::format_linuxcnc_offsets_ini(curves, "guideway-offsets.hal", a.ratio)}},
      {});
  std::cout << std::fixed << std::setprecision(3);
  for (const auto& c : curves) {
    std::cout << c.corrected_axis << " corrected by " << c.moving_axis << "'s position: " << c.position_mm.size()
              << " points from " << c.position_mm.front() << " to " << c.position_mm.back() << " mm, offset "
              << c.offset_mm.front() * 1e3 << " .. " << c.offset_mm.back() * 1e3 << " um at the ends";
    if (c.resampling_error_mm > 0)
      std::cout << ", within " << c.resampling_error_mm * 1e3 << " um of the straightness table";
    std::cout << "\n";
  }
  std::cout << "wrote " << (dir / "guideway-offsets.hal").string() << " and " << (dir / "linuxcnc-offsets.ini").string()
            << "\n";
}

void add_linuxcnc_commands(CLI::App& app, CliContext& ctx) {
  auto* group = app.add_subcommand("linuxcnc", "LinuxCNC: corrections it can load beyond its per-joint tables");
  group->require_subcommand(1);
  add_commands(*group, ctx,
               {command("offsets",
                        "the squareness and straightness of a compensation directory as LinuxCNC's external offsets "
                        "(a HAL file of lincurve lookups and the INI lines; docs/linuxcnc.md)",
                        &run_offsets)});
}

const CommandGroup group(&add_linuxcnc_commands);

}  // namespace

}  // namespace guideway::cli
