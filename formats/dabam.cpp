// DABAM slope profiles as the database stores them (dabam.hpp): the .dat columns read by the .txt metadata's indices
// and factors.
#include "formats/dabam.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include <nlohmann/json.hpp>

#include "core/csv_table.hpp"
#include "core/number_format.hpp"

namespace guideway::formats {

namespace {

std::string at_line(const std::string& source, std::size_t line) { return source + ":" + std::to_string(line) + ": "; }

// A metadata value as a number: a JSON number or a string holding one (some entries quote them); nullopt when
// absent, null or an empty string.
std::optional<double> number_of(const nlohmann::json& meta, const char* key, const std::string& source) {
  const auto it = meta.find(key);
  if (it == meta.end() || it->is_null()) return std::nullopt;
  if (it->is_number()) {
    const double v = it->get<double>();
    if (std::isfinite(v)) return v;
  } else if (it->is_string()) {
    const auto text = it->get<std::string>();
    if (text.find_first_not_of(" \t") == std::string::npos) return std::nullopt;  // "" (some entries): not stated
    if (const auto v = parse_double(text)) return v;
  }
  throw CsvError(source + ": " + key + " = " + it->dump() + " is not a number");
}

double required_number(const nlohmann::json& meta, const char* key, const std::string& source) {
  const auto v = number_of(meta, key, source);
  if (!v) throw CsvError(source + ": " + key + " is missing (a DABAM entry's metadata states it)");
  return *v;
}

// A whole number within [lo, hi], or `fallback` when absent; the first of `keys` that is present.
std::size_t index_of(const nlohmann::json& meta, std::initializer_list<const char*> keys, std::size_t fallback,
                     std::size_t hi, const std::string& source) {
  for (const char* key : keys)
    if (const auto v = number_of(meta, key, source)) {
      if (!(*v >= 0 && *v <= static_cast<double>(hi) && *v == std::floor(*v)))
        throw CsvError(source + ": " + key + " = " + shortest(*v) + " is not a whole number in [0, " +
                       std::to_string(hi) + "]");
      return static_cast<std::size_t>(*v);
    }
  return fallback;
}

std::string text_of(const nlohmann::json& meta, const char* key) {
  const auto it = meta.find(key);
  if (it == meta.end() || it->is_null()) return "";
  if (it->is_string()) return it->get<std::string>();
  return it->dump();  // a bare number (SURFACE_SHAPE 1 in some entries)
}

double factor_of(const nlohmann::json& meta, const char* key, const char* what, const std::string& source) {
  const double f = required_number(meta, key, source);
  if (!(std::abs(f) >= 1e-12 && std::abs(f) <= 1e3))
    throw CsvError(source + ": " + key + " = " + shortest(f) + " is outside +-[1e-12, 1e3] (" + what + ")");
  return f;
}

std::vector<std::string_view> blank_split(std::string_view line) {
  std::vector<std::string_view> cells;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) cells.push_back(line.substr(start, i - start));
  }
  return cells;
}

std::string sibling(const std::string& path, const char* ext) { return path.substr(0, path.size() - 4) + ext; }

}  // namespace

bool is_dabam_path(std::string_view path) {
  return path.size() > 4 && (path.ends_with(".dat") || path.ends_with(".txt"));
}

DabamProfile parse_dabam(std::string_view dat, std::string_view txt, const std::string& dat_source,
                         const std::string& txt_source) {
  nlohmann::json meta;
  try {
    meta = nlohmann::json::parse(txt);
  } catch (const nlohmann::json::exception& e) {
    throw CsvError(txt_source + ": not DABAM metadata (a JSON object): " + e.what());
  }
  if (!meta.is_object()) throw CsvError(txt_source + ": not DABAM metadata (a JSON object)");
  DabamProfile p;
  p.source = dat_source;
  p.metadata_source = txt_source;
  const double format = required_number(meta, "FILE_FORMAT", txt_source);
  if (format == 2 || format == 4)
    throw CsvError(txt_source + ": FILE_FORMAT = " + shortest(format) +
                   " is a height profile; only slope profiles (FILE_FORMAT 1 or 3) are read");
  if (format != 1 && format != 3)
    throw CsvError(txt_source + ": FILE_FORMAT = " + shortest(format) + " is not a DABAM format (1 or 3: slopes)");
  p.file_format = static_cast<int>(format);
  const std::size_t header = index_of(meta, {"FILE_HEADER_LINES"}, 0, dabam_max_header_lines, txt_source);
  const std::size_t cx = index_of(meta, {"COLUMN_INDEX_ABSCISSA", "COLUMN_INDEX_ABSCISSAS"}, 0, 100, txt_source);
  const std::size_t cy = index_of(meta, {"COLUMN_INDEX_ORDINATE", "COLUMN_INDEX_ORDINATES"}, 1, 100, txt_source);
  if (cx == cy) throw CsvError(txt_source + ": the abscissa and the profile are both column " + std::to_string(cx));
  const double x_factor = factor_of(meta, "X1_FACTOR", "the abscissa's unit in metres", txt_source);
  const double y_factor = factor_of(meta, "Y1_FACTOR", "the slope's unit in radians", txt_source);
  p.surface_shape = text_of(meta, "SURFACE_SHAPE");
  p.facility = text_of(meta, "FACILITY");
  p.instrument = text_of(meta, "INSTRUMENT");
  if (const auto length = number_of(meta, "LENGTH", txt_source)) p.length_m = *length;

  std::size_t line_no = 0, pos = 0;
  const std::size_t need = std::max(cx, cy) + 1;
  while (pos < dat.size()) {
    std::size_t end = dat.find('\n', pos);
    if (end == std::string_view::npos) end = dat.size();
    const std::string_view line = dat.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (line_no <= header) continue;
    const auto cells = blank_split(line);
    if (cells.empty()) continue;
    if (cells.size() < need)
      throw CsvError(at_line(dat_source, line_no) + std::to_string(cells.size()) + " column(s); the metadata needs " +
                     std::to_string(need) + " (abscissa column " + std::to_string(cx) + ", profile column " +
                     std::to_string(cy) + ")");
    const auto x = parse_double(cells[cx]), y = parse_double(cells[cy]);
    if (!x || !y)
      throw CsvError(at_line(dat_source, line_no) + "'" + std::string(x ? cells[cy] : cells[cx]) +
                     "' is not a number (after " + std::to_string(header) + " header line(s))");
    if (p.x_m.size() == dabam_max_readings)
      throw CsvError(at_line(dat_source, line_no) + "more than " + std::to_string(dabam_max_readings) + " readings");
    const double x_m = *x * x_factor, slope = *y * y_factor;
    if (!(std::abs(x_m) <= dabam_max_abs_x_m))
      throw CsvError(at_line(dat_source, line_no) + "x = " + significant_digits(x_m, 10) + " m is outside +-" +
                     shortest(dabam_max_abs_x_m) + " m");
    if (!(std::abs(slope) <= dabam_max_abs_slope_rad))
      throw CsvError(at_line(dat_source, line_no) + "slope = " + significant_digits(slope, 10) + " rad is outside +-" +
                     shortest(dabam_max_abs_slope_rad) + " rad (a slope profile's plausible bound)");
    p.x_m.push_back(x_m);
    p.slope_rad.push_back(slope);
    p.line.push_back(line_no);
  }
  if (p.x_m.size() < 2)
    throw CsvError(dat_source + ": " + std::to_string(p.x_m.size()) + " reading(s) after " + std::to_string(header) +
                   " header line(s); a profile needs at least 2");
  // One way along the mirror: increasing, or decreasing (then read in the other order; a slope dh/dx keeps its
  // sign whichever way the positions were listed).
  const bool decreasing = p.x_m[1] < p.x_m[0];
  for (std::size_t i = 1; i < p.x_m.size(); ++i)
    if (decreasing ? !(p.x_m[i] < p.x_m[i - 1]) : !(p.x_m[i] > p.x_m[i - 1]))
      throw CsvError(at_line(dat_source, p.line[i]) + "x = " + significant_digits(p.x_m[i], 10) + " m does not " +
                     (decreasing ? "decrease" : "increase") + " (previous " + significant_digits(p.x_m[i - 1], 10) +
                     " m)");
  if (decreasing) {
    std::reverse(p.x_m.begin(), p.x_m.end());
    std::reverse(p.slope_rad.begin(), p.slope_rad.end());
    std::reverse(p.line.begin(), p.line.end());
  }
  return p;
}

DabamProfile read_dabam(const std::string& path) {
  if (!is_dabam_path(path))
    throw CsvError(path + ": not a DABAM entry (NAME.dat with its metadata NAME.txt beside it)");
  const std::string dat = path.ends_with(".dat") ? path : sibling(path, ".dat");
  const std::string txt = path.ends_with(".txt") ? path : sibling(path, ".txt");
  const std::string dat_text = read_text_file(dat);
  std::string txt_text;
  try {
    txt_text = read_text_file(txt);
  } catch (const CsvError& e) {
    throw CsvError(std::string(e.what()) + " (a DABAM entry's metadata, beside " + dat + ")");
  }
  return parse_dabam(dat_text, txt_text, dat, txt);
}

}  // namespace guideway::formats
