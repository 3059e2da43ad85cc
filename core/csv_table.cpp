#include "core/csv_table.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <sstream>

namespace guideway {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::string at(const std::string& source, std::size_t line) { return source + ":" + std::to_string(line) + ": "; }

char pick_delimiter(std::string_view line) {
  for (char c : {',', '\t', ';'}) {
    if (line.find(c) != std::string_view::npos) return c;
  }
  return ' ';  // blanks
}

std::vector<std::string> split(std::string_view line, char delim) {
  std::vector<std::string> cells;
  if (delim == ' ') {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      const std::size_t start = i;
      while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
      if (i > start) cells.emplace_back(line.substr(start, i - start));
    }
    return cells;
  }
  std::size_t start = 0;
  while (true) {
    const std::size_t end = line.find(delim, start);
    cells.emplace_back(trim(line.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start)));
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
  return cells;
}

std::string join_columns(const std::vector<std::string>& cols) {
  std::string out;
  for (const auto& c : cols) out += (out.empty() ? "" : ", ") + ("'" + c + "'");
  return out;
}

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

std::string read_text_file(const std::string& path) {
  if (path == "-") return std::string(std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>());
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CsvError(path + ": cannot read (" + std::strerror(errno) + ")");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw CsvError(path + ": read error");
  return ss.str();
}

CsvTable read_csv_table(const std::string& path) {
  return parse_csv_table(read_text_file(path), path == "-" ? std::string("<stdin>") : path);
}

CsvTable parse_csv_table(std::string_view text, const std::string& source) {
  CsvTable t;
  t.source = source;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  char delim = 0;
  std::size_t line_no = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t nl = text.find('\n', pos);
    std::string_view line = text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    ++line_no;
    line = trim(line);
    if (line.empty()) continue;
    if (line.front() == '#') {
      const std::string_view body = trim(line.substr(1));
      const std::size_t eq = body.find('=');
      if (eq != std::string_view::npos && eq > 0) {
        const std::string key(trim(body.substr(0, eq)));
        if (key.find(' ') == std::string::npos) t.metadata[key] = std::string(trim(body.substr(eq + 1)));
      }
      continue;
    }
    if (line.find('\0') != std::string_view::npos)
      throw CsvError(at(source, line_no) + "binary data, not a text table");
    if (delim == 0) {
      delim = pick_delimiter(line);
      auto cells = split(line, delim);
      bool all_numbers = true;
      for (const auto& c : cells) all_numbers = all_numbers && parse_double(c).has_value();
      if (!all_numbers) {
        for (std::size_t i = 0; i < cells.size(); ++i) {
          if (cells[i].empty())
            throw CsvError(at(source, line_no) + "header column " + std::to_string(i + 1) + " has no name");
          for (std::size_t j = 0; j < i; ++j) {
            if (cells[j] == cells[i])
              throw CsvError(at(source, line_no) + "column '" + cells[i] + "' appears twice in the header");
          }
        }
        t.columns = std::move(cells);
        t.header_line = line_no;
        continue;
      }
      if (cells.size() == 1) {
        t.columns = {"value"};
      } else {
        for (std::size_t i = 0; i < cells.size(); ++i) t.columns.push_back("column" + std::to_string(i + 1));
      }
    }
    auto cells = split(line, delim);
    if (cells.size() != t.columns.size()) {
      throw CsvError(at(source, line_no) + std::to_string(cells.size()) + " cells, expected " +
                     std::to_string(t.columns.size()) +
                     (t.header_line != 0 ? " (the header's columns)" : " (as the first row)"));
    }
    t.rows.push_back({line_no, std::move(cells)});
  }
  if (t.columns.empty()) throw CsvError(source + ": no header and no data");
  return t;
}

std::optional<std::size_t> CsvTable::find_column(std::string_view name) const {
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i] == name) return i;
  }
  return std::nullopt;
}

std::size_t CsvTable::column(std::string_view name) const {
  if (auto i = find_column(name)) return *i;
  // At the header row, when there is one: that is the line to fix.
  const std::string at = header_line != 0 ? source + ":" + std::to_string(header_line) : source;
  throw CsvError(at + ": no column '" + std::string(name) + "' (columns: " + join_columns(columns) + ")");
}

double CsvTable::number(const Row& row, std::size_t col) const {
  const std::string& cell = row.cells.at(col);
  if (auto v = parse_double(cell)) return *v;
  if (cell.empty()) throw CsvError(at(source, row.line) + "column '" + columns.at(col) + "': empty cell");
  throw CsvError(at(source, row.line) + "column '" + columns.at(col) + "': '" + cell + "' is not a finite number");
}

std::vector<double> CsvTable::numbers(std::size_t col) const {
  if (col >= columns.size()) throw CsvError(source + ": column index " + std::to_string(col) + " out of range");
  std::vector<double> out;
  out.reserve(rows.size());
  for (const auto& r : rows) out.push_back(number(r, col));
  return out;
}

std::size_t CsvTable::select_column(const std::optional<std::string>& name) const {
  if (name) return column(*name);
  if (columns.size() == 1) return 0;
  throw CsvError(source + ": " + std::to_string(columns.size()) + " columns (" + join_columns(columns) +
                 "): choose one with --column");
}

double CsvTable::metadata_number(const std::string& key) const {
  auto it = metadata.find(key);
  if (it == metadata.end()) throw CsvError(source + ": missing metadata line '# " + key + " = <number>'");
  if (auto v = parse_double(it->second)) return *v;
  throw CsvError(source + ": metadata '" + key + "' = '" + it->second + "' is not a number");
}

std::optional<double> CsvTable::optional_metadata_number(const std::string& key) const {
  if (metadata.find(key) == metadata.end()) return std::nullopt;
  return metadata_number(key);
}

}  // namespace guideway
