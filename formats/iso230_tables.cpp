// The error map as volumetric compensations read it (iso230_tables.hpp): ISO 230-1 named tables, written and read back.
#include "formats/iso230_tables.hpp"

#include <cmath>
#include <sstream>

#include "core/csv_table.hpp"
#include "core/number_format.hpp"

namespace guideway::formats {

namespace {

[[noreturn]] void fail(const std::string& where, const std::string& message) {
  throw Iso230TableError(where + ": " + message);
}

void comments(std::ostringstream& o, const std::vector<std::string>& lines) {
  for (const auto& l : lines) o << "#" << (l.empty() ? "" : " ") << l << "\n";
}

CsvTable parse(std::string_view text, const std::string& name) {
  try {
    return parse_csv_table(text, name);
  } catch (const CsvError& e) {
    throw Iso230TableError(e.what());
  }
}

void check_format(const CsvTable& t, const char* id, const std::string& name) {
  const auto f = t.metadata.find("format");
  if (f == t.metadata.end() || f->second != id) fail(name, std::string("not a table of format ") + id);
}

double finite_number(const CsvTable& t, const CsvTable::Row& row, std::size_t col) {
  try {
    return t.number(row, col);
  } catch (const CsvError& e) {
    throw Iso230TableError(e.what());
  }
}

}  // namespace

std::array<std::string, 7> iso230_columns(char axis) {
  const char a = static_cast<char>(axis - 'x' + 'X');
  std::array<std::string, 7> c;
  c[0] = std::string(1, a);
  const char* parts = "XYZABC";
  for (int k = 0; k < 6; ++k) c[static_cast<std::size_t>(k + 1)] = std::string("E") + parts[k] + a;
  return c;
}

std::string format_iso230_axis_table(const Iso230AxisTable& t, const std::vector<std::string>& comment_lines) {
  if (t.axis < 'x' || t.axis > 'z') fail("ISO 230-1 table", "axis must be x, y or z");
  const std::size_t n = t.position_mm.size();
  if (n < 2) fail("ISO 230-1 table", "needs at least 2 positions");
  for (const auto& col : t.values)
    if (col.size() != n) fail("ISO 230-1 table", "every column needs one value per position");
  std::ostringstream o;
  o << "# format = " << iso230_table_format_id << "\n# axis = " << t.axis << "\n";
  for (const auto& [k, v] : t.metadata) o << "# " << k << " = " << v << "\n";
  comments(o, comment_lines);
  const auto cols = iso230_columns(t.axis);
  for (std::size_t k = 0; k < cols.size(); ++k) o << (k ? "," : "") << cols[k];
  o << "\n";
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(t.position_mm[i]) || (i > 0 && !(t.position_mm[i] > t.position_mm[i - 1])))
      fail("ISO 230-1 table", "positions must be finite and strictly ascending");
    o << shortest(t.position_mm[i]);
    for (const auto& col : t.values) {
      if (!std::isfinite(col[i])) fail("ISO 230-1 table", "a value is not finite");
      o << "," << shortest(col[i]);
    }
    o << "\n";
  }
  return o.str();
}

Iso230AxisTable parse_iso230_axis_table(std::string_view text, const std::string& name) {
  const CsvTable t = parse(text, name);
  check_format(t, iso230_table_format_id, name);
  Iso230AxisTable out;
  const auto a = t.metadata.find("axis");
  if (a == t.metadata.end() || a->second.size() != 1 || a->second[0] < 'x' || a->second[0] > 'z')
    fail(name, "metadata 'axis' must be x, y or z");
  out.axis = a->second[0];
  for (const auto& [k, v] : t.metadata)
    if (k != "format" && k != "axis") out.metadata.emplace_back(k, v);
  const auto cols = iso230_columns(out.axis);
  std::array<std::size_t, 7> at{};
  for (std::size_t k = 0; k < cols.size(); ++k) {
    const auto c = t.find_column(cols[k]);
    if (!c) fail(name + ":" + std::to_string(t.header_line), "missing column '" + cols[k] + "'");
    at[k] = *c;
  }
  for (const auto& row : t.rows) {
    const double p = finite_number(t, row, at[0]);
    if (!out.position_mm.empty() && !(p > out.position_mm.back()))
      fail(name + ":" + std::to_string(row.line), "position " + shortest(p) + " does not ascend");
    out.position_mm.push_back(p);
    for (std::size_t k = 0; k < 6; ++k) out.values[k].push_back(finite_number(t, row, at[k + 1]));
  }
  if (out.position_mm.size() < 2) fail(name, "needs at least 2 positions");
  return out;
}

Iso230AxisTable read_iso230_axis_table(const std::string& path) {
  try {
    return parse_iso230_axis_table(read_text_file(path), path);
  } catch (const CsvError& e) {
    throw Iso230TableError(e.what());
  }
}

std::string format_iso230_squareness(const Iso230Squareness& q, const std::vector<std::string>& comment_lines) {
  std::ostringstream o;
  o << "# format = " << iso230_squareness_format_id << "\n";
  for (const auto& [k, v] : q.metadata) o << "# " << k << " = " << v << "\n";
  comments(o, comment_lines);
  for (double v : {q.ec0y_urad, q.eb0z_urad, q.ea0z_urad})
    if (!std::isfinite(v)) fail("ISO 230-1 squareness", "a value is not finite");
  o << "name,value_urad\nEC0Y," << shortest(q.ec0y_urad) << "\nEB0Z," << shortest(q.eb0z_urad) << "\nEA0Z,"
    << shortest(q.ea0z_urad) << "\n";
  return o.str();
}

Iso230Squareness parse_iso230_squareness(std::string_view text, const std::string& name) {
  const CsvTable t = parse(text, name);
  check_format(t, iso230_squareness_format_id, name);
  Iso230Squareness q;
  for (const auto& [k, v] : t.metadata)
    if (k != "format") q.metadata.emplace_back(k, v);
  const auto cn = t.find_column("name"), cv = t.find_column("value_urad");
  if (!cn || !cv) fail(name, "expected the columns name,value_urad");
  bool seen[3] = {false, false, false};
  for (const auto& row : t.rows) {
    const std::string n(t.cell(row, *cn));
    const double v = finite_number(t, row, *cv);
    const int i = n == "EC0Y" ? 0 : n == "EB0Z" ? 1 : n == "EA0Z" ? 2 : -1;
    if (i < 0) fail(name + ":" + std::to_string(row.line), "unknown squareness '" + n + "' (EC0Y, EB0Z, EA0Z)");
    if (seen[i]) fail(name + ":" + std::to_string(row.line), n + " given twice");
    seen[i] = true;
    (i == 0 ? q.ec0y_urad : i == 1 ? q.eb0z_urad : q.ea0z_urad) = v;
  }
  if (!seen[0] || !seen[1] || !seen[2]) fail(name, "needs EC0Y, EB0Z and EA0Z");
  return q;
}

Iso230Squareness read_iso230_squareness(const std::string& path) {
  try {
    return parse_iso230_squareness(read_text_file(path), path);
  } catch (const CsvError& e) {
    throw Iso230TableError(e.what());
  }
}

}  // namespace guideway::formats
