// Compensation files (compensation_files.hpp): LinuxCNC's per-joint tables, the INI lines that load them, read back and
// checked.
#include "formats/compensation_files.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

#include "core/csv_table.hpp"
#include "core/number_format.hpp"

namespace guideway::formats {

namespace {

[[noreturn]] void fail(const std::string& name, const std::string& message) {
  throw CompensationFileError(name + ": " + message);
}

void check_table(const std::vector<CompTriplet>& table, const std::string& name) {
  if (table.empty())
    fail(name, "no compensation triplets (LinuxCNC reads `nominal forward reverse` lines from the top)");
  if (table.size() > linuxcnc_comp_max_lines)
    fail(name, std::to_string(table.size()) + " lines; LinuxCNC keeps at most " +
                   std::to_string(linuxcnc_comp_max_lines) + " per joint (use a coarser step)");
  for (std::size_t i = 0; i < table.size(); ++i) {
    const auto& t = table[i];
    if (!std::isfinite(t.nominal_mm) || !std::isfinite(t.forward_mm) || !std::isfinite(t.reverse_mm))
      fail(name, "line " + std::to_string(i + 1) + ": a value is not a finite number");
    if (i > 0 && !(t.nominal_mm > table[i - 1].nominal_mm))
      fail(name, "line " + std::to_string(i + 1) + ": nominal " + shortest(t.nominal_mm) +
                     " mm does not increase (LinuxCNC refuses a table whose nominal positions do not ascend)");
  }
}

// Fixed notation with 6 decimals (1 nm in mm): what a user reads, and what LinuxCNC's %lf takes.
std::string mm(double v) { return printf_number("%.6f", v); }

void comments(std::ostringstream& o, const std::vector<std::string>& lines, const char* prefix) {
  for (const auto& l : lines) o << prefix << (l.empty() ? "" : " ") << l << "\n";
}

}  // namespace

std::string format_linuxcnc_comp(const std::vector<CompTriplet>& table, const std::vector<std::string>& comment_lines) {
  check_table(table, "compensation table");
  std::ostringstream o;
  for (const auto& t : table) o << mm(t.nominal_mm) << " " << mm(t.forward_mm) << " " << mm(t.reverse_mm) << "\n";
  comments(o, comment_lines, "#");
  return o.str();
}

std::vector<CompTriplet> parse_linuxcnc_comp(std::string_view text, const std::string& name) {
  std::vector<CompTriplet> out;
  std::size_t pos = 0, line_no = 0;
  while (pos < text.size()) {
    const std::size_t nl = text.find('\n', pos);
    std::istringstream fields{std::string(text.substr(pos, std::min<std::size_t>(nl, text.size()) - pos).substr(0, 256))};
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    ++line_no;
    CompTriplet t;
    if (!(fields >> t.nominal_mm >> t.forward_mm >> t.reverse_mm)) break;
    try {
      check_row_count(out.size() + 1, name, line_no);
    } catch (const CsvError& e) {
      throw CompensationFileError(e.what());
    }
    out.push_back(t);
  }
  check_table(out, name);
  return out;
}

std::vector<CompTriplet> read_linuxcnc_comp(const std::string& path) {
  try {
    return parse_linuxcnc_comp(read_text_file(path), path);
  } catch (const CsvError& e) {
    throw CompensationFileError(e.what());
  }
}

std::string format_linuxcnc_ini(const std::vector<IniJoint>& joints, const std::vector<std::string>& comment_lines) {
  std::ostringstream o;
  comments(o, comment_lines, ";");
  for (const auto& j : joints) {
    o << "\n[JOINT_" << j.joint << "]\n";
    o << "; axis " << j.axis << ": add these lines to the existing [JOINT_" << j.joint << "] section\n";
    o << "COMP_FILE = " << j.comp_file << "\n";
    o << "COMP_FILE_TYPE = 0\n";
    o << "; the table's forward and reverse columns already hold the lost motion (LinuxCNC ignores BACKLASH\n";
    o << "; when COMP_FILE is set); 0 keeps it from being corrected twice if the table is removed\n";
    o << "BACKLASH = 0\n";
  }
  return o.str();
}

std::string format_error_map_csv(const std::vector<ErrorMapRow>& rows,
                                 const std::vector<std::pair<std::string, std::string>>& metadata,
                                 const std::vector<std::string>& comment_lines) {
  std::ostringstream o;
  o << "# format = " << error_map_format_id << "\n";
  for (const auto& [k, v] : metadata) o << "# " << k << " = " << v << "\n";
  comments(o, comment_lines, "#");
  o << "axis,position_mm,forward_um,reverse_um,straightness_axis,straightness_um\n";
  for (const auto& r : rows) {
    if (!std::isfinite(r.position_mm) || !std::isfinite(r.forward_um) || !std::isfinite(r.reverse_um) ||
        !std::isfinite(r.straightness_um))
      fail("errors.csv", "axis " + r.axis + ": a value is not a finite number");
    o << r.axis << "," << printf_number("%.4f", r.position_mm) << "," << printf_number("%.4f", r.forward_um) << ","
      << printf_number("%.4f", r.reverse_um) << "," << r.across << "," << printf_number("%.4f", r.straightness_um)
      << "\n";
  }
  return o.str();
}

namespace {

constexpr const char* straightness_header = "moving_axis,position_mm,corrected_axis,correction_mm";

void check_cross_rows(const std::vector<CrossCorrectionRow>& rows, const std::string& name) {
  if (rows.empty()) fail(name, "no cross-axis corrections");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& r = rows[i];
    const std::string where = "row " + std::to_string(i + 1) + ": ";
    if (r.moving_axis.empty() || r.corrected_axis.empty() || r.moving_axis == r.corrected_axis)
      fail(name, where + "moving axis \"" + r.moving_axis + "\" and corrected axis \"" + r.corrected_axis +
                     "\" must be two different axes");
    if (!std::isfinite(r.position_mm) || !std::isfinite(r.correction_mm))
      fail(name, where + "a value is not a finite number");
    if (i > 0 && rows[i - 1].moving_axis == r.moving_axis && rows[i - 1].corrected_axis == r.corrected_axis &&
        !(r.position_mm > rows[i - 1].position_mm))
      fail(name, where + "position " + shortest(r.position_mm) + " mm of " + r.moving_axis +
                     " does not increase (a table interpolated in that position needs ascending positions)");
  }
}

}  // namespace

std::string format_straightness_csv(const std::vector<CrossCorrectionRow>& rows,
                                    const std::vector<std::pair<std::string, std::string>>& metadata,
                                    const std::vector<std::string>& comment_lines) {
  check_cross_rows(rows, "straightness.csv");
  std::ostringstream o;
  o << "# format = " << straightness_format_id << "\n";
  for (const auto& [k, v] : metadata) o << "# " << k << " = " << v << "\n";
  comments(o, comment_lines, "#");
  o << straightness_header << "\n";
  for (const auto& r : rows)
    o << r.moving_axis << "," << printf_number("%.4f", r.position_mm) << "," << r.corrected_axis << ","
      << mm(r.correction_mm) << "\n";
  return o.str();
}

std::vector<CrossCorrectionRow> parse_straightness_csv(std::string_view text, const std::string& name) {
  std::vector<CrossCorrectionRow> rows;
  try {
    const CsvTable t = parse_csv_table(text, name);
    const auto f = t.metadata.find("format");
    if (f == t.metadata.end() || f->second != straightness_format_id)
      fail(name, std::string("not a straightness table (expected \"# format = ") + straightness_format_id + "\")");
    const std::size_t moving = t.column("moving_axis"), position = t.column("position_mm"),
                      corrected = t.column("corrected_axis"), correction = t.column("correction_mm");
    for (const auto& r : t.rows)
      rows.push_back({std::string(t.cell(r, moving)), t.number(r, position), std::string(t.cell(r, corrected)),
                      t.number(r, correction)});
  } catch (const CsvError& e) {
    throw CompensationFileError(e.what());
  }
  check_cross_rows(rows, name);
  return rows;
}

std::vector<CrossCorrectionRow> read_straightness_csv(const std::string& path) {
  try {
    return parse_straightness_csv(read_text_file(path), path);
  } catch (const CsvError& e) {
    throw CompensationFileError(e.what());
  }
}

}  // namespace guideway::formats
