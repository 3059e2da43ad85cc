#pragma once
// Profile files from disk (docs/formats.md, "Profile files (CSV, X3P)"): our CSV profile format
// (x_mm,z_um with "# key = value" metadata) and ISO 5436-2 X3P containers, whose rows are
// extracted as profiles. A function API for the CLI and the tests; pure except for reading the file.
// Errors are ProfileFileError exceptions naming the file (and line for CSV).

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace guideway::formats {

class ProfileFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One profile: heights z_m (NaN = invalid point) at positions x_m, plus metadata in file order.
struct Profile {
  std::vector<double> x_m;
  std::vector<double> z_m;
  std::vector<std::pair<std::string, std::string>> metadata;
  [[nodiscard]] std::optional<std::string> meta(std::string_view key) const;
  // Equal spacing of x (metres) when the points are equally spaced within 1e-6 relative, else nullopt.
  [[nodiscard]] std::optional<double> spacing_m() const;
};

// The plausible range of a profile's points (docs/formats.md): |x| <= 10 m (a machine's travel), |z| <= 10 mm
// (a profilometer's range); a point outside is refused at its line. X3P increments lie in (0, 1 m].
inline constexpr double profile_max_abs_x_m = 10.0;
inline constexpr double profile_max_abs_z_m = 10e-3;
inline constexpr double profile_max_increment_m = 1.0;

// --- CSV: "# key = value" lines, a header row naming x and z with units (x_mm | x_um | x_m,
// z_um | z_nm | z_mm | z_m; other columns are ignored), then rows; an empty or "nan" z is invalid.
Profile parse_profile_csv(std::string_view text, const std::string& name);
Profile read_profile_csv(const std::string& path);
// Writes format = guideway/profile/1, the metadata, then x_mm,z_um rows (shortest round-trip digits).
std::string format_profile_csv(const Profile& profile);
void write_profile_csv(const std::string& path, const Profile& profile);

// --- X3P (ISO 5436-2): a zip with main.xml and the binary point data.
struct X3pSurface {
  std::string feature_type;  // "SUR" (areal) or "PRF" (profile)
  std::size_t size_x = 0, size_y = 0, size_z = 0;
  double increment_x_m = 0.0, increment_y_m = 0.0;
  double offset_x_m = 0.0, offset_y_m = 0.0;
  char data_type = 'D';     // CZ: D float64, F float32, L int32, I int16
  std::vector<double> z_m;  // size_x * size_y (first layer), x fastest; NaN = invalid point
  std::vector<std::pair<std::string, std::string>> metadata;  // creator, date, instrument, ...
  [[nodiscard]] double at(std::size_t ix, std::size_t iy) const { return z_m[iy * size_x + ix]; }
};

X3pSurface parse_x3p(std::string_view archive, const std::string& name);
X3pSurface read_x3p(const std::string& path);
// Row iy as a profile along x (metadata: source, row, y_mm, plus the surface's metadata).
Profile x3p_row(const X3pSurface& surface, std::size_t iy, const std::string& source = {});
std::vector<Profile> x3p_profiles(const X3pSurface& surface, const std::string& source = {});
// Builds an X3P archive (float64 data, incremental X/Y axes) from a surface, for tests and export.
std::string build_x3p(const X3pSurface& surface, bool deflate);

// Any profile file by extension: .csv gives one profile, .x3p one per row.
std::vector<Profile> read_profiles(const std::string& path);

// The text of the element at path (e.g. {"Record1", "Axes", "CX", "Increment"}) in a small XML
// document; nullopt when absent; "" for an empty or self-closing element. Exposed for tests.
std::optional<std::string_view> xml_text(std::string_view doc, std::initializer_list<std::string_view> path);

}  // namespace guideway::formats
