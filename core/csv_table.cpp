// The reader of Guideway's text tables and plain number columns (csv_table.hpp).
#include "core/csv_table.hpp"

#include "core/number_format.hpp"

#include <algorithm>
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

constexpr std::size_t max_columns = 4096;  // a table's columns: a header of a 2 GB line would not fit in memory

std::string at(const std::string& source, std::size_t line) { return source + ":" + std::to_string(line) + ": "; }

char pick_delimiter(std::string_view line) {
  for (char c : {',', '\t', ';'}) {
    if (line.find(c) != std::string_view::npos) return c;
  }
  return ' ';  // blanks
}

// Calls f(cell) for each cell of `line` (trimmed), in order; allocates nothing.
template <class F>
void for_each_cell(std::string_view line, char delim, F&& f) {
  if (delim == ' ') {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      const std::size_t start = i;
      while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
      if (i > start) f(line.substr(start, i - start));
    }
    return;
  }
  std::size_t start = 0;
  while (true) {
    const std::size_t end = line.find(delim, start);
    f(trim(line.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start)));
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
}

std::vector<std::string> split(std::string_view line, char delim) {
  std::vector<std::string> cells;
  for_each_cell(line, delim, [&](std::string_view c) { cells.emplace_back(c); });
  return cells;
}

std::size_t cell_count(std::string_view line, char delim) {
  std::size_t n = 0;
  for_each_cell(line, delim, [&](std::string_view) { ++n; });
  return n;
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

namespace {
CsvTable parse_owned(std::string owned, const std::string& source);
}  // namespace

CsvTable read_csv_table(const std::string& path) {
  return parse_owned(read_text_file(path), path == "-" ? std::string("<stdin>") : path);
}

CsvTable parse_csv_table(std::string_view text, const std::string& source) {
  return parse_owned(std::string(text), source);
}

namespace {

CsvTable parse_owned(std::string owned, const std::string& source) {
  CsvTable t;
  t.source = source;
  t.text = std::move(owned);
  std::string_view text = t.text;
  t.rows.reserve(static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) + 1);  // no doubling's slack
  const std::size_t bom = text.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0;
  text.remove_prefix(bom);
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
        if (key.find(' ') == std::string::npos) {
          t.metadata[key] = std::string(trim(body.substr(eq + 1)));
          t.metadata_line[key] = line_no;
        }
      }
      continue;
    }
    if (line.find('\0') != std::string_view::npos)
      throw CsvError(at(source, line_no) + "binary data, not a text table");
    if (delim == 0) {
      delim = pick_delimiter(line);
      if (cell_count(line, delim) > max_columns)
        throw CsvError(at(source, line_no) + "more than " + std::to_string(max_columns) + " columns");
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
    if (const std::size_t cells = cell_count(line, delim); cells != t.columns.size()) {
      throw CsvError(at(source, line_no) + std::to_string(cells) + " cells, expected " +
                     std::to_string(t.columns.size()) +
                     (t.header_line != 0 ? " (the header's columns)" : " (as the first row)"));
    }
    check_row_count(t.rows.size() + 1, source, line_no);
    const auto begin = static_cast<std::size_t>(line.data() - t.text.data());
    t.rows.push_back({line_no, begin, begin + line.size()});
  }
  if (t.columns.empty()) throw CsvError(source + ": no header and no data");
  t.delimiter = delim;
  return t;
}

}  // namespace

std::string_view CsvTable::cell(const Row& row, std::size_t col) const {
  const std::string_view line = std::string_view(text).substr(row.begin, row.end - row.begin);
  std::string_view out;
  std::size_t i = 0;
  bool found = false;
  for_each_cell(line, delimiter, [&](std::string_view c) {
    if (i++ == col) {
      out = c;
      found = true;
    }
  });
  if (!found) throw CsvError(at(source, row.line) + "no cell " + std::to_string(col + 1));
  return out;
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
  const std::string_view c = cell(row, col);
  if (auto v = parse_double(c)) return *v;
  if (c.empty()) throw CsvError(at(source, row.line) + "column '" + columns.at(col) + "': empty cell");
  throw CsvError(at(source, row.line) + "column '" + columns.at(col) + "': '" + std::string(c.substr(0, 80)) +
                 "' is not a finite number");
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
  throw CsvError(at(source, metadata_line.at(key)) + "metadata '" + key + "' = '" + it->second.substr(0, 80) +
                 "' is not a number");
}

namespace {

std::string outside(double v, double lo, double hi, std::string_view what) {
  return " = " + shortest(v) + " is outside [" + shortest(lo) + ", " + shortest(hi) + "] " + std::string(what);
}

}  // namespace

double CsvTable::number_in(const Row& row, std::size_t col, double lo, double hi, std::string_view what) const {
  const double v = number(row, col);
  if (!(v >= lo && v <= hi)) throw CsvError(at(source, row.line) + columns.at(col) + outside(v, lo, hi, what));
  return v;
}

double CsvTable::metadata_in(const std::string& key, double lo, double hi, std::string_view what) const {
  const double v = metadata_number(key);
  if (!(v >= lo && v <= hi)) throw CsvError(at(source, metadata_line.at(key)) + key + outside(v, lo, hi, what));
  return v;
}

std::optional<double> CsvTable::optional_metadata_in(const std::string& key, double lo, double hi,
                                                     std::string_view what) const {
  if (metadata.find(key) == metadata.end()) return std::nullopt;
  return metadata_in(key, lo, hi, what);
}

std::optional<double> CsvTable::optional_metadata_number(const std::string& key) const {
  if (metadata.find(key) == metadata.end()) return std::nullopt;
  return metadata_number(key);
}

}  // namespace guideway
