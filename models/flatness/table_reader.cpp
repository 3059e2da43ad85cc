#include "models/flatness/table_reader.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

namespace guideway::models {

namespace {

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r");
  return s.substr(first, last - first + 1);
}

std::vector<std::string> split_cells(std::string_view line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    cells.emplace_back(
        trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return cells;
}

std::string where(const std::string& source, std::size_t line) { return source + ":" + std::to_string(line) + ": "; }

}  // namespace

std::optional<double> parse_double(std::string_view text) {
  text = trim(text);
  if (text.empty()) return std::nullopt;
  if (text.front() == '+') text.remove_prefix(1);
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || ptr != text.data() + text.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<std::size_t> TableFile::find_column(std::string_view name) const {
  for (std::size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == name) return i;
  return std::nullopt;
}

std::size_t TableFile::column(std::string_view name) const {
  if (auto i = find_column(name)) return *i;
  throw InputError(where(source, header_line) + "missing column '" + std::string(name) + "'");
}

double TableFile::number(const Row& row, std::size_t col) const {
  const std::string& name = col < columns.size() ? columns[col] : std::to_string(col + 1);
  if (col >= row.cells.size() || row.cells[col].empty())
    throw InputError(where(source, row.line) + "column '" + name + "' is empty");
  if (auto v = parse_double(row.cells[col])) return *v;
  throw InputError(where(source, row.line) + "column '" + name + "': '" + row.cells[col] + "' is not a number");
}

std::optional<double> TableFile::optional_metadata_number(const std::string& key) const {
  const auto it = metadata.find(key);
  if (it == metadata.end()) return std::nullopt;
  if (auto v = parse_double(it->second)) return v;
  throw InputError(source + ": metadata '" + key + " = " + it->second + "' is not a number");
}

double TableFile::metadata_number(const std::string& key) const {
  if (auto v = optional_metadata_number(key)) return *v;
  throw InputError(source + ": missing metadata line '# " + key + " = <number>'");
}

TableFile parse_table(std::string_view text, const std::string& source) {
  TableFile t;
  t.source = source;
  std::size_t line_no = 0;
  std::size_t pos = 0;
  while (pos <= text.size()) {
    auto eol = text.find('\n', pos);
    if (eol == std::string_view::npos) eol = text.size();
    const std::string_view raw = text.substr(pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    const std::string_view line = trim(raw);
    if (line.empty()) {
      if (eol == text.size()) break;
      continue;
    }
    if (line.front() == '#') {
      const std::string_view body = trim(line.substr(1));
      const auto eq = body.find('=');
      if (eq != std::string_view::npos) {
        const std::string key(trim(body.substr(0, eq)));
        if (!key.empty() && key.find(' ') == std::string::npos)
          t.metadata[key] = std::string(trim(body.substr(eq + 1)));
      }
      continue;
    }
    if (t.columns.empty()) {
      t.columns = split_cells(line);
      t.header_line = line_no;
      continue;
    }
    TableFile::Row row;
    row.line = line_no;
    row.cells = split_cells(line);
    if (row.cells.size() != t.columns.size())
      throw InputError(where(source, line_no) + std::to_string(row.cells.size()) + " cells, but the header has " +
                       std::to_string(t.columns.size()) + " columns");
    t.rows.push_back(std::move(row));
  }
  if (t.columns.empty()) throw InputError(source + ": no header row (column names) found");
  return t;
}

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read (" + std::strerror(errno) + ")");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TableFile read_table(const std::string& path) { return parse_table(read_text_file(path), path); }

}  // namespace guideway::models
