#pragma once
// What a controller loads from an error map (docs/map.md "Exports"): the ISO 230-1-named tables a volumetric
// compensation reads (formats/iso230_tables: per axis `X,EXX,EYX,EZX,EAX,EBX,ECX`, and EC0Y, EB0Z, EA0Z), the
// LinuxCNC per-joint tables (the error along each axis' line through the volume's centre, with the ballbar's
// backlash in their forward and reverse columns) and the INI lines, the cross-axis straightness table of the
// same lines (what a per-axis controller can take of the rest), and the plain map (its functions on a grid,
// CSV). And the controller's side: the tool point's error computed from the tables alone, as a volumetric
// compensation does (linear interpolation between table lines, the map's chain). Pure functions; thread safe.

#include <array>
#include <string>
#include <vector>

#include "formats/iso230_tables.hpp"
#include "models/map/error_map.hpp"
#include "models/map/fit.hpp"

namespace guideway::models::map {

struct ExportOptions {
  double step_m = 0.0;  // table spacing; 0: the finest of 0.5, 1, 2, 2.5, 5, 10, ... mm within LinuxCNC's 256 lines
};

struct ExportFile {
  std::string name;
  std::string content;
};

// The spacing `options` gives for the map's longest travel (throws std::invalid_argument for one that gives
// more than 256 lines or is not positive and finite).
double table_step_m(const ErrorMap& map, const ExportOptions& options);

// The ISO tables of the map: an axis' six functions at every step over its travel (0 where not determined).
formats::Iso230AxisTable iso230_table(const ErrorMap& map, int axis, double step_m);
formats::Iso230Squareness iso230_squareness(const ErrorMap& map);

// Every file, by name: iso230_x.csv, iso230_y.csv, iso230_z.csv, iso230_squareness.csv, x.comp, y.comp,
// z.comp, linuxcnc.ini, straightness.csv, map_functions.csv. `source` names the map in the headers.
std::vector<ExportFile> map_exports(const ErrorMap& map, const std::vector<AxisBacklash>& backlash,
                                    const ExportOptions& options, const std::string& source);
// The names map_exports gives (what a new set written to a directory replaces).
std::vector<std::string> map_export_names();

// The tables as a volumetric compensation holds them.
struct TableMap {
  std::array<formats::Iso230AxisTable, 3> axes;
  formats::Iso230Squareness squareness;
  std::array<int, 3> chain{1, 0, 2};
};
// Reads iso230_{x,y,z}.csv and iso230_squareness.csv from `dir` (the chain from their metadata). Throws
// formats::Iso230TableError naming the file.
TableMap read_table_map(const std::string& dir);
// The tool point's error at `position` with the tool at `tool_offset`, from the tables: each function
// interpolated linearly (its end values beyond the table), through the first-order chain.
Vec3 table_tool_error(const TableMap& tables, const Vec3& position, const Vec3& tool_offset);

}  // namespace guideway::models::map
