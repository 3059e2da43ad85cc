#pragma once
// The error map as the volumetric compensations of controllers read it (docs/formats.md "ISO 230-1 error
// tables"; Siemens VCS, Heidenhain KinematicsComp, ISG/Beckhoff's volumetric compensation take tables named
// after the ISO 230-1 errors): one table per axis, its position against the axis' six error motions, columns
// `X,EXX,EYX,EZX,EAX,EBX,ECX` (for Y: `Y,EXY,...,ECY`; positions in mm, translations in um, rotations in
// urad), and the three position-independent squarenesses EC0Y, EB0Z, EA0Z (urad, ISO 230-1 signs). Format
// guideway/iso230-table/1 and guideway/iso230-squareness/1 in `# key = value` metadata. Readers check what the
// writers guarantee (the columns by name, positions strictly ascending, every value finite) and name the file
// and line. Pure functions; thread safe.

#include <array>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace guideway::formats {

inline constexpr const char* iso230_table_format_id = "guideway/iso230-table/1";
inline constexpr const char* iso230_squareness_format_id = "guideway/iso230-squareness/1";

class Iso230TableError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Iso230AxisTable {
  char axis = 'x';  // 'x', 'y' or 'z'
  std::vector<double> position_mm;
  // E_X, E_Y, E_Z (um) and E_A, E_B, E_C (urad) of this axis, one value per position each.
  std::array<std::vector<double>, 6> values;
  std::vector<std::pair<std::string, std::string>> metadata;  // besides format and axis (read back as written)
};

// The column names of an axis' table: "X", "EXX", "EYX", "EZX", "EAX", "EBX", "ECX".
std::array<std::string, 7> iso230_columns(char axis);

std::string format_iso230_axis_table(const Iso230AxisTable& table, const std::vector<std::string>& comment_lines);
Iso230AxisTable parse_iso230_axis_table(std::string_view text, const std::string& name);
Iso230AxisTable read_iso230_axis_table(const std::string& path);

struct Iso230Squareness {
  double ec0y_urad = 0.0;  // Y to X, about z
  double eb0z_urad = 0.0;  // Z to X, about y
  double ea0z_urad = 0.0;  // Z to Y, about x
  std::vector<std::pair<std::string, std::string>> metadata;
};
std::string format_iso230_squareness(const Iso230Squareness& q, const std::vector<std::string>& comment_lines);
Iso230Squareness parse_iso230_squareness(std::string_view text, const std::string& name);
Iso230Squareness read_iso230_squareness(const std::string& path);

}  // namespace guideway::formats
