#pragma once
// DABAM slope profiles as the database stores them (docs/formats.md "DABAM slope profile"; Sanchez del Rio
// et al., J. Synchrotron Rad. 23 (2016) 665): an entry is `NAME.dat` (whitespace-separated columns after
// FILE_HEADER_LINES header lines) and `NAME.txt` beside it (one JSON object: FILE_FORMAT, the column indices,
// X1_FACTOR to metres, Y1_FACTOR to radians with its sign, and the mirror's description). Only slope profiles
// (FILE_FORMAT 1 or 3) are read. Pure except for reading the files; errors are CsvError "file:line: message"
// (or "file: message").

#include <cstddef>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace guideway::formats {

// The readers' bounds (a value outside is refused at its line, naming the bound).
inline constexpr std::size_t dabam_max_readings = 100000;  // the straightness traverse's most a pass
inline constexpr double dabam_max_abs_x_m = 100.0;         // a profile within 100 m of its origin
inline constexpr double dabam_max_abs_slope_rad = 0.1;     // 5.7 deg: no mirror or guideway slopes more
inline constexpr std::size_t dabam_max_header_lines = 10000;

struct DabamProfile {
  std::string source;             // the .dat file
  std::string metadata_source;    // the .txt file
  std::vector<double> x_m;        // abscissa (X1_FACTOR applied), increasing (rows reversed when the file decreases)
  std::vector<double> slope_rad;  // the profile (Y1_FACTOR applied, its sign counted): dh/dx
  std::vector<std::size_t> line;  // .dat line of each reading
  int file_format = 1;
  // As the metadata states them ("" when absent or null).
  std::string surface_shape, facility, instrument;
  double length_m = std::numeric_limits<double>::quiet_NaN();  // LENGTH (NaN when absent)
};

// `dat` and `txt`: the two files' texts, named dat_source and txt_source in messages.
DabamProfile parse_dabam(std::string_view dat, std::string_view txt, const std::string& dat_source,
                         const std::string& txt_source);
// `path`: the entry's .dat or .txt file; the other is the same name with the other extension.
DabamProfile read_dabam(const std::string& path);
// A path the DABAM reader takes: it ends in .dat or .txt (a traverse or profile file is .csv).
bool is_dabam_path(std::string_view path);

}  // namespace guideway::formats
