#pragma once
// What the `guideway map` commands and `guideway compensate map` share: the day's tests from files and from
// the daemon's latest sessions, the map printed for people, the exports written as one set.

#include <iosfwd>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli/commands.hpp"
#include "models/map/map_inputs.hpp"

namespace guideway::cli {

// Run files, traverse files, artifact directories (calibration.csv, horizontal.csv, vertical.csv; lying at
// `artifact_other_m`) and run-out files added to the inputs.
void add_file_inputs(models::map::MapInputs& in, const std::vector<std::string>& dbb,
                     const std::vector<std::string>& traverses, const std::vector<std::string>& artifacts,
                     const models::map::Vec3& artifact_other_m, const std::vector<std::string>& runouts);
// The daemon's latest DBB session (its run files), straightness session of each axis (its traverse file) and
// runout session (its revolution file); a kind with no session yet is said on `notes`, not thrown.
void add_latest_inputs(models::map::MapInputs& in, const std::string& socket, std::ostream& notes);

// The map file's JSON (models/map/map_json to_json(MapFit)) for people: the 21 errors with their
// uncertainties and the tests they come from, what the day could not determine and why, the cross-checks,
// the volumetric accuracy, the tests' residuals.
void print_map(const nlohmann::json& map);
void print_volumetric(const nlohmann::json& volumetric, const std::string& title);

// The map's report (report/: its sections and pictures) to `path`.
void write_map_report(const nlohmann::json& map, const std::string& path);

// Writes `content` to `path` (whole or not at all). Throws std::runtime_error naming the path.
void write_text_file(const std::string& path, const std::string& content);

// The exports of the map file `map_path` written into `out_dir` as one set (each file to NAME.part, then all
// renamed); returns the paths written. step_m 0: the default step.
std::vector<std::string> export_map(const std::string& map_path, const std::string& out_dir, double step_m);

// `guideway map sequence` (cli/map_sequence.cpp).
void add_map_sequence_command(CLI::App& map, CliContext& ctx);

}  // namespace guideway::cli
