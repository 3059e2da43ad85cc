#pragma once
// Compensation files (docs/formats.md, "Compensation files", and docs/compensation.md): LinuxCNC's
// per-joint compensation tables (COMP_FILE_TYPE = 0), the [JOINT_n] INI lines that load them, and
// Guideway's generic error map `errors.csv`. Writers check what LinuxCNC checks when it loads a
// table (nominal strictly ascending, at most 256 lines) so a file it would refuse is never written.
// Pure functions; thread safe. Errors are CompensationFileError naming the file (and line).

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace guideway::formats {

class CompensationFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// LinuxCNC's table size (EMCMOT_COMP_SIZE): it refuses entries beyond this many.
inline constexpr std::size_t linuxcnc_comp_max_lines = 256;

// One COMP_FILE_TYPE = 0 line: the nominal (commanded) joint position and the actual positions the
// joint reaches there when moving in the positive and in the negative direction (mm).
struct CompTriplet {
  double nominal_mm = 0.0;
  double forward_mm = 0.0;
  double reverse_mm = 0.0;
};

// The triplets, then `comment_lines` each prefixed with "# ". The comments follow the table on
// purpose: LinuxCNC's reader (usrmotLoadComp) stops at the first line that is not three numbers,
// so a comment above the table would leave the joint uncompensated. Throws CompensationFileError
// when the nominal positions are not strictly ascending, there are more than 256 or none, or a value
// is not finite.
std::string format_linuxcnc_comp(const std::vector<CompTriplet>& table, const std::vector<std::string>& comment_lines);
// Reads a table as LinuxCNC does: triplets from the first line until the first line that is not three
// numbers; then checks them as format_linuxcnc_comp does. `name` is used in messages.
std::vector<CompTriplet> parse_linuxcnc_comp(std::string_view text, const std::string& name);
std::vector<CompTriplet> read_linuxcnc_comp(const std::string& path);

// The [JOINT_n] lines that load one table.
struct IniJoint {
  int joint = 0;          // LinuxCNC joint number (trivkins: x = 0, y = 1, z = 2)
  std::string axis;       // "x", for the comment
  std::string comp_file;  // as written in the INI (relative to the configuration directory)
};
// ';' comment lines, then one [JOINT_n] section per joint with COMP_FILE, COMP_FILE_TYPE = 0 and
// BACKLASH = 0 (the table's forward and reverse columns already hold the lost motion; LinuxCNC ignores
// BACKLASH when COMP_FILE is given, and 0 says so to the next reader).
std::string format_linuxcnc_ini(const std::vector<IniJoint>& joints, const std::vector<std::string>& comment_lines);

// errors.csv: one row per axis and position, every error component in um; `# key = value` metadata
// (format = guideway/error-map/1) and `#` comment lines first.
struct ErrorMapRow {
  std::string axis;          // the moving axis: "x"
  double position_mm = 0.0;  // nominal position in machine coordinates
  double forward_um = 0.0;   // positioning error (actual - nominal) moving in +
  double reverse_um = 0.0;   // moving in -
  std::string across;        // the axis along which `straightness_um` is measured: "y"
  double straightness_um = 0.0;
};
inline constexpr const char* error_map_format_id = "guideway/error-map/1";
std::string format_error_map_csv(const std::vector<ErrorMapRow>& rows,
                                 const std::vector<std::pair<std::string, std::string>>& metadata,
                                 const std::vector<std::string>& comment_lines);

// straightness.csv: the cross-axis (straightness) correction. For each moving axis and position, the
// correction (mm) the controller adds to the command of the other plane axis, interpolated linearly in
// the moving axis' commanded position; `# key = value` metadata (format = guideway/straightness/1) and
// `#` comment lines first. Rows of one moving axis and corrected axis are consecutive, positions strictly
// ascending (a moving axis may correct both other axes: the error map's straightness in both directions).
struct CrossCorrectionRow {
  std::string moving_axis;     // "x": the axis whose position indexes the correction
  double position_mm = 0.0;    // its nominal position in machine coordinates
  std::string corrected_axis;  // "y": the axis whose command is corrected
  double correction_mm = 0.0;  // added to the corrected axis' command (= minus the straightness there)
};
inline constexpr const char* straightness_format_id = "guideway/straightness/1";
// Throws CompensationFileError when the rows are empty, a value is not finite, an axis corrects itself
// or the positions of a moving axis' rows for one corrected axis do not ascend.
std::string format_straightness_csv(const std::vector<CrossCorrectionRow>& rows,
                                    const std::vector<std::pair<std::string, std::string>>& metadata,
                                    const std::vector<std::string>& comment_lines);
// Reads what format_straightness_csv writes, with the same checks; `name` is used in messages.
std::vector<CrossCorrectionRow> parse_straightness_csv(std::string_view text, const std::string& name);
std::vector<CrossCorrectionRow> read_straightness_csv(const std::string& path);

}  // namespace guideway::formats
