// What the map is fitted to (map_inputs.hpp): each day's test result in the terms the map's observation model reads.
#include "models/map/map_inputs.hpp"

#include <cctype>
#include <cmath>

#include "core/csv_table.hpp"
#include "core/units.hpp"
#include "models/flatness/angles.hpp"

namespace guideway::models::map {

std::optional<int> parse_axis(std::string_view name) {
  if (name.size() != 1) return std::nullopt;
  const char c = static_cast<char>(std::tolower(static_cast<unsigned char>(name[0])));
  if (c < 'x' || c > 'z') return std::nullopt;
  return c - 'x';
}

std::array<int, 3> plane_axes(const std::string& plane) {
  if (plane == "xz") return {0, 2, 1};
  if (plane == "yz") return {1, 2, 0};
  return {0, 1, 2};
}

double run_center_n_m(const formats::DbbRun& run) {
  const auto it = run.metadata.find("center_n_mm");
  if (it == run.metadata.end()) return 0.0;
  const auto v = parse_double(it->second);
  if (!v) throw CsvError(run.source + ": metadata 'center_n_mm' is not a number");
  return *v * 1e-3;
}

ArtifactTest artifact_test(const artifact::ArtifactResult& result, const Vec3& other_m, const std::string& source) {
  ArtifactTest t;
  t.source = source;
  t.axis = result.axis;
  t.other_m = other_m;
  for (const auto& e : result.targets) {
    const artifact::MachineErrors m = artifact::machine_errors(e, result.axis);
    t.position_m.push_back(e.x_m);
    t.displacement_m.push_back(m.d);
    t.u_displacement_m.push_back(m.u_d);
    t.rotation_rad.push_back(m.r);
    t.u_rotation_rad.push_back(m.u_r);
    t.roll_again_rad.push_back(e.ex_vertical_rad);
    t.u_roll_again_rad.push_back(e.u_ex_vertical_rad);
  }
  return t;
}

double pitch_rotation_sign(int axis) { return flatness::traverse_pitch_sign(axis); }
double yaw_rotation_sign(int axis) { return flatness::traverse_yaw_sign(axis); }

TraverseTest parse_traverse_test(std::string_view text, const std::string& source, std::optional<int> axis,
                                 double u_angle_rad) {
  const CsvTable t = parse_csv_table(text, source);
  TraverseTest out;
  out.source = source;
  const auto meta_axis = t.metadata.find("axis");
  std::optional<int> file_axis;
  if (meta_axis != t.metadata.end()) {
    file_axis = parse_axis(meta_axis->second);
    if (!file_axis) throw CsvError(source + ": axis is '" + meta_axis->second + "', expected x, y or z");
  }
  out.axis = axis.value_or(file_axis.value_or(0));
  const double step = t.metadata_number("step_mm") * 1e-3;
  if (!(step > 0)) throw CsvError(source + ": metadata 'step_mm' must be positive");
  // Without an axis the file is a reflector on feet (x_mm its rear foot): the carriage is midway.
  const double to_carriage = file_axis ? 0.0 : step / 2;
  const std::size_t cx = t.column("x_mm");
  const std::size_t cp = t.column("pitch_arcsec");
  const auto cy = t.find_column("yaw_arcsec");
  const auto ct = t.find_column("t_s");
  const auto cpass = t.find_column("pass");
  for (const auto& row : t.rows) {
    out.position_m.push_back(t.number(row, cx) * 1e-3 + to_carriage);
    out.pitch_rad.push_back(pitch_rotation_sign(out.axis) * t.number(row, cp) * rad_per_arcsec);
    if (cy) out.yaw_rad.push_back(yaw_rotation_sign(out.axis) * t.number(row, *cy) * rad_per_arcsec);
    if (ct) out.t_s.push_back(t.number(row, *ct));
    const double pass = cpass ? t.number(row, *cpass) : 1.0;
    if (pass != std::round(pass) || pass < 1 || pass > 1000)
      throw CsvError(source + ":" + std::to_string(row.line) + ": pass must be a whole number from 1");
    out.pass.push_back(static_cast<int>(pass));
  }
  if (out.position_m.size() < 3) throw CsvError(source + ": a traverse of the map needs at least 3 readings");
  // TA80: resolution 0.01", accuracy 0.5" (models/flatness/angles.hpp): 0.289" a reading.
  out.u_angle_rad = u_angle_rad > 0 ? u_angle_rad
                                    : std::sqrt(0.01 * 0.01 / 12.0 + 0.5 * 0.5 / 3.0) * rad_per_arcsec;
  return out;
}

TraverseTest read_traverse_test(const std::string& path, std::optional<int> axis, double u_angle_rad) {
  return parse_traverse_test(read_text_file(path), path, axis, u_angle_rad);
}

}  // namespace guideway::models::map
