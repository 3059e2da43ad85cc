// DBB run files (dbb_run.hpp): the CSV with `# key = value` metadata, written and read back with every row validated.
#include "formats/dbb_run.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <numbers>
#include <sstream>

#include "core/input_file.hpp"
#include "core/number_format.hpp"
#include "formats/raw_recording.hpp"

namespace guideway::formats {

namespace {

constexpr double deg = std::numbers::pi / 180.0;

std::string_view trim_view(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r");
  return std::string(s.substr(b, e - b + 1));
}

[[noreturn]] void fail(const std::string& source, std::size_t line, const std::string& msg) {
  std::string where = source;
  if (line != 0) where += ":" + std::to_string(line);
  throw DbbRunFormatError(where + ": " + msg);
}

bool parse_double(const std::string& s, double& out) {
  const char* b = s.data();
  const char* e = s.data() + s.size();
  auto [p, ec] = std::from_chars(b, e, out);
  if (ec == std::errc() && p == e) return true;
  // from_chars rejects "nan"/"inf" spellings on some libraries; accept them so we can say "not finite".
  std::string low;
  for (char c : s) low += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (low == "nan" || low == "-nan" || low == "+nan") {
    out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  if (low == "inf" || low == "+inf" || low == "-inf" || low == "infinity" || low == "-infinity") {
    out = low[0] == '-' ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    return true;
  }
  return false;
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : line) {
    if (c == ',') {
      out.push_back(trim(cur));
      cur.clear();
    } else {
      cur += c;
    }
  }
  out.push_back(trim(cur));
  return out;
}

double meta_number(const DbbRun& run, const std::map<std::string, std::size_t>& lines, const std::string& key,
                   bool required, double fallback) {
  const auto it = run.metadata.find(key);
  if (it == run.metadata.end()) {
    if (required) fail(run.source, 0, "missing metadata line `# " + key + " = ...`");
    return fallback;
  }
  double v = 0;
  if (!parse_double(it->second, v) || !std::isfinite(v)) {
    fail(run.source, lines.at(key), key + ": expected a finite number, got \"" + it->second + "\"");
  }
  const DbbPlausible* bound = nullptr;
  for (const DbbPlausible& b : dbb_plausible_metadata)
    if (b.key == key) bound = &b;
  const bool inside = !bound || ((bound->min_open ? v > bound->min : v >= bound->min) && v <= bound->max);
  if (!inside)
    fail(run.source, lines.at(key),
         key + " = " + it->second + " is outside " + (bound->min_open ? "(" : "[") + shortest(bound->min) + ", " +
             shortest(bound->max) + "] " + std::string(bound->unit) + ", " + std::string(bound->what));
  return v;
}

// A data row's cells (comma separated, trimmed), without allocating; false when there are not `n`.
bool cells_of(std::string_view line, std::size_t n, std::vector<std::string_view>& out) {
  out.clear();
  std::size_t start = 0;
  while (out.size() <= n) {
    const std::size_t end = line.find(',', start);
    std::string_view c = line.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start);
    while (!c.empty() && (c.front() == ' ' || c.front() == '\t' || c.front() == '\r')) c.remove_prefix(1);
    while (!c.empty() && (c.back() == ' ' || c.back() == '\t' || c.back() == '\r')) c.remove_suffix(1);
    out.push_back(c);
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
  return out.size() == n;
}

}  // namespace

double DbbRun::nominal_length_m() const { return std::sqrt(radius_m * radius_m + height_m * height_m); }

namespace {

double median_step_rad(const DbbRun& run) {
  if (run.angle_rad.size() < 2) return 0.0;
  std::vector<double> steps(run.angle_rad.size() - 1);
  for (std::size_t i = 1; i < run.angle_rad.size(); ++i)
    steps[i - 1] = std::abs(run.angle_rad[i] - run.angle_rad[i - 1]);
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  return steps[steps.size() / 2];
}

std::string fixed(double v, int digits) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(digits) << v;
  return o.str();
}

}  // namespace

std::vector<DbbGap> dbb_run_gaps(const DbbRun& run) {
  std::vector<DbbGap> out;
  const std::size_t n = std::min({run.angle_rad.size(), run.t_s.size()});
  const double limit = std::max(5.0 * median_step_rad(run), 0.5 * deg);
  for (std::size_t i = 1; i < n; ++i)
    if (std::abs(run.angle_rad[i] - run.angle_rad[i - 1]) > limit)
      out.push_back({i - 1, run.angle_rad[i - 1], run.angle_rad[i], run.t_s[i - 1], run.t_s[i]});
  return out;
}

double dbb_run_arc_rad(const DbbRun& run) {
  if (run.angle_rad.size() < 2) return 0.0;
  return std::abs(run.angle_rad.back() - run.angle_rad.front()) + median_step_rad(run);
}

double dbb_run_covered_rad(const DbbRun& run) {
  const double step = median_step_rad(run);
  double covered = dbb_run_arc_rad(run);
  for (const DbbGap& g : dbb_run_gaps(run)) covered -= g.angle_rad() - step;
  return covered;
}

std::string describe_gap(const DbbGap& g) {
  return "gap of " + fixed(g.angle_rad() / deg, 1) + " deg (" + fixed(g.duration_s(), 2) + " s) from " +
         fixed(g.from_rad / deg, 1) + " to " + fixed(g.to_rad / deg, 1) + " deg (t " + fixed(g.from_s, 2) + " to " +
         fixed(g.to_s, 2) + " s, after sample " + std::to_string(g.after) + ")";
}

void validate_dbb_run(const DbbRun& run) {
  const std::string& src = run.source;
  if (!(run.radius_m > 0) || !std::isfinite(run.radius_m)) fail(src, 0, "radius_mm must be a positive number");
  if (!(run.height_m >= 0) || !std::isfinite(run.height_m)) fail(src, 0, "height_mm must be zero or positive");
  if (!(run.feed_m_per_s > 0) || !std::isfinite(run.feed_m_per_s)) fail(src, 0, "feed_mm_per_min must be positive");
  if (run.plane != "xy" && run.plane != "xz" && run.plane != "yz")
    fail(src, 0, "plane must be xy, xz or yz, got \"" + run.plane + "\"");
  const std::size_t n = run.angle_rad.size();
  if (run.t_s.size() != n || run.dL_m.size() != n) fail(src, 0, "columns t_s, angle_deg and dL_um differ in length");
  if (n < dbb_min_samples)
    fail(src, 0,
         "too few samples: " + std::to_string(n) + ", need at least " + std::to_string(dbb_min_samples) +
             " on the data arc");
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(run.t_s[i]) || !std::isfinite(run.angle_rad[i]) || !std::isfinite(run.dL_m[i]))
      fail(src, 0, "sample " + std::to_string(i) + " is not a finite number (NaN or infinity)");
  }
  const double span = run.angle_rad.back() - run.angle_rad.front();
  const int dir = run.dir();
  if (span * dir <= 0)
    fail(src, 0,
         std::string("angles run ") + (span > 0 ? "counter-clockwise" : "clockwise") +
             " but the metadata says direction = " + (dir > 0 ? "ccw" : "cw"));
  for (std::size_t i = 1; i < n; ++i) {
    if ((run.angle_rad[i] - run.angle_rad[i - 1]) * dir < 0)
      fail(src, 0,
           "angle goes backwards at sample " + std::to_string(i) + " (direction " + (dir > 0 ? "ccw" : "cw") + ")");
    if (run.t_s[i] < run.t_s[i - 1]) fail(src, 0, "time goes backwards at sample " + std::to_string(i));
  }
  if (!(run.t_s.back() > run.t_s.front()))
    fail(src, 0, "t_s does not advance: every sample is at t = " + shortest(run.t_s.front()) + " s");
  const double arc = dbb_run_arc_rad(run);
  if (arc > 361.0 * deg)
    fail(src, 0, "the samples span " + fixed(arc / deg, 1) + " deg: a run is one circle, 360 deg at most");
  if (arc < dbb_min_arc_deg * deg)
    fail(src, 0,
         "partial arc: the samples cover " + fixed(arc / deg, 1) + " deg, a DBB run needs an arc of at least " +
             fixed(dbb_min_arc_deg, 0) + " deg");
  if (run.data_arc_rad != 0) {
    if (!(run.data_arc_rad >= dbb_min_arc_deg * deg) || run.data_arc_rad > 360.0 * deg + 1e-9)
      fail(src, 0, "data_arc_deg must be between 180 and 360, got " + fixed(run.data_arc_rad / deg, 1));
    if (arc > run.data_arc_rad + 1.0 * deg)
      fail(src, 0,
           "the samples span " + fixed(arc / deg, 1) +
               " deg, more than the stated data arc (data_arc_deg = " + fixed(run.data_arc_rad / deg, 1) + ")");
  }
  const double covered = dbb_run_covered_rad(run);
  if (covered < dbb_min_arc_deg * deg) {
    std::string gaps;
    for (const DbbGap& g : dbb_run_gaps(run)) gaps += (gaps.empty() ? "" : "; ") + describe_gap(g);
    fail(src, 0,
         "after its gaps the samples cover only " + fixed(covered / deg, 1) + " deg of the " + fixed(arc / deg, 1) +
             " deg arc, at least " + fixed(dbb_min_arc_deg, 0) + " deg must be left (" + gaps + ")");
  }
  double max_dl = 0;
  for (double d : run.dL_m) max_dl = std::max(max_dl, std::abs(d));
  if (max_dl > 1e-3) {
    std::ostringstream m;
    m << "dL reaches " << std::fixed << std::setprecision(1) << max_dl * 1e6
      << " um: the bar length does not match the metadata (radius_mm = " << run.radius_m * 1e3
      << ", height_mm = " << run.height_m * 1e3 << ", nominal length " << run.nominal_length_m() * 1e3 << " mm)";
    fail(src, 0, m.str());
  }
}

DbbRun parse_dbb_run(const std::string& text, const std::string& source) {
  DbbRun run;
  run.source = source;
  std::map<std::string, std::size_t> meta_line;
  std::size_t lineno = 0;
  std::vector<std::string> header;
  std::size_t header_line = 0;
  int col_t = -1, col_a = -1, col_d = -1;
  std::vector<double> angle_deg;
  std::vector<std::string_view> f;
  std::size_t pos = 0;
  while (pos < text.size()) {  // views of the text: a line costs nothing beyond the file's own bytes
    const std::size_t nl = text.find('\n', pos);
    const std::string_view line = std::string_view(text).substr(pos, nl == std::string::npos ? std::string::npos : nl - pos);
    pos = nl == std::string::npos ? text.size() : nl + 1;
    ++lineno;
    const std::string_view tl = trim_view(line);
    if (tl.empty()) continue;
    if (tl[0] == '#') {
      const std::string body = trim(tl.substr(1));
      const auto eq = body.find('=');
      if (eq == std::string::npos) continue;  // a plain comment
      const std::string key = trim(std::string_view(body).substr(0, eq));
      const std::string value = trim(std::string_view(body).substr(eq + 1));
      if (key.empty()) fail(source, lineno, "metadata line without a key");
      if (run.metadata.count(key)) {
        if (!header.empty()) continue;  // trailer lines may not redefine the header's keys
        fail(source, lineno, "metadata key \"" + key + "\" given twice");
      }
      run.metadata[key] = value;
      meta_line[key] = lineno;
      continue;
    }
    if (header.empty()) {
      if (std::count(tl.begin(), tl.end(), ',') >= dbb_max_columns)
        fail(source, lineno, "header row has more than " + std::to_string(dbb_max_columns) + " columns");
      header = split(std::string(tl));
      header_line = lineno;
      for (std::size_t i = 0; i < header.size(); ++i) {
        if (header[i] == "t_s") col_t = static_cast<int>(i);
        if (header[i] == "angle_deg") col_a = static_cast<int>(i);
        if (header[i] == "dL_um") col_d = static_cast<int>(i);
      }
      if (col_t < 0 || col_a < 0 || col_d < 0)
        fail(source, lineno,
             "header row must name the columns t_s, angle_deg and dL_um, got \"" + std::string(tl.substr(0, 200)) +
                 "\"");
      continue;
    }
    if (!cells_of(tl, header.size(), f))
      fail(source, lineno,
           "expected " + std::to_string(header.size()) + " fields, got " +
               (f.size() > header.size() ? "more" : std::to_string(f.size())));
    try {
      check_row_count(run.t_s.size() + 1, source, lineno);
    } catch (const CsvError& e) {
      throw DbbRunFormatError(e.what());
    }
    double vals[3];
    const int cols[3] = {col_t, col_a, col_d};
    for (int k = 0; k < 3; ++k) {
      const std::string cell(f[static_cast<std::size_t>(cols[k])].substr(0, 80));
      const std::string& name = header[static_cast<std::size_t>(cols[k])];
      if (!parse_double(cell, vals[k])) fail(source, lineno, name + ": \"" + cell + "\" is not a number");
      if (!std::isfinite(vals[k])) fail(source, lineno, name + " is not a finite number (" + cell + ")");
      const DbbPlausible& b = dbb_plausible_columns[static_cast<std::size_t>(k)];
      if (k == 2 && std::abs(vals[k]) > b.max) {
        const auto meta = [&](const char* key) {
          const auto it = run.metadata.find(key);
          return it == run.metadata.end() ? std::string("?") : it->second.substr(0, 40);
        };
        fail(source, lineno,
             "dL_um = " + cell + " is outside [-" + shortest(b.max) + ", " + shortest(b.max) +
                 "] um: the bar length does not match the metadata (radius_mm = " + meta("radius_mm") +
                 ", height_mm = " + meta("height_mm") + ")");
      }
      if (std::abs(vals[k]) > b.max)
        fail(source, lineno,
             name + " = " + cell + " is outside [-" + shortest(b.max) + ", " + shortest(b.max) + "] " + std::string(b.unit) +
                 ", " + std::string(b.what));
    }
    if (!run.t_s.empty() && vals[0] < run.t_s.back())
      fail(source, lineno, "t_s = " + shortest(vals[0]) + " s goes back (the row before: " + shortest(run.t_s.back()) + " s)");
    run.t_s.push_back(vals[0]);
    angle_deg.push_back(vals[1]);
    run.dL_m.push_back(vals[2] * 1e-6);
  }
  if (header.empty()) fail(source, lineno, "no header row `t_s,angle_deg,dL_um` found");
  (void)header_line;
  const auto fmt = run.metadata.find("format");
  if (fmt == run.metadata.end())
    fail(source, 0, "missing metadata line `# format = " + std::string(dbb_run_format_id) + "`");
  if (fmt->second != dbb_run_format_id)
    fail(source, meta_line["format"], "format is \"" + fmt->second + "\", expected \"" + dbb_run_format_id + "\"");
  run.radius_m = meta_number(run, meta_line, "radius_mm", true, 0) * 1e-3;
  run.height_m = meta_number(run, meta_line, "height_mm", true, 0) * 1e-3;
  run.feed_m_per_s = meta_number(run, meta_line, "feed_mm_per_min", true, 0) * 1e-3 / 60.0;
  run.center_a_m = meta_number(run, meta_line, "center_a_mm", false, 0) * 1e-3;
  run.center_b_m = meta_number(run, meta_line, "center_b_mm", false, 0) * 1e-3;
  run.data_arc_rad = meta_number(run, meta_line, "data_arc_deg", false, 0) * deg;
  for (const DbbPlausible& b : dbb_plausible_metadata)  // the optional ones read elsewhere: checked here
    (void)meta_number(run, meta_line, std::string(b.key), false, 0);
  if (run.metadata.count("data_arc_deg") && !(run.data_arc_rad > 0))
    fail(source, meta_line["data_arc_deg"], "data_arc_deg must be a positive number of degrees");
  const auto d = run.metadata.find("direction");
  if (d == run.metadata.end()) fail(source, 0, "missing metadata line `# direction = ccw|cw`");
  if (d->second == "ccw") {
    run.direction = DbbDirection::ccw;
  } else if (d->second == "cw") {
    run.direction = DbbDirection::cw;
  } else {
    fail(source, meta_line["direction"], "direction must be ccw or cw, got \"" + d->second + "\"");
  }
  const auto p = run.metadata.find("plane");
  if (p == run.metadata.end()) fail(source, 0, "missing metadata line `# plane = xy|xz|yz`");
  run.plane = p->second;
  if (const auto nl = run.metadata.find("nominal_length_mm"); nl != run.metadata.end()) {
    const double given = meta_number(run, meta_line, "nominal_length_mm", false, 0) * 1e-3;
    if (std::abs(given - run.nominal_length_m()) > 1e-6) {
      std::ostringstream m;
      m << "nominal_length_mm = " << given * 1e3
        << " does not match sqrt(radius_mm^2 + height_mm^2) = " << run.nominal_length_m() * 1e3;
      fail(source, meta_line["nominal_length_mm"], m.str());
    }
  }
  // Unwrap angles written modulo 360.
  run.angle_rad.reserve(angle_deg.size());
  double offset = 0;
  for (std::size_t i = 0; i < angle_deg.size(); ++i) {
    if (i > 0) {
      const double jump = angle_deg[i] + offset - (run.angle_rad.back() / deg);
      if (jump > 180.0) offset -= 360.0;
      if (jump < -180.0) offset += 360.0;
    }
    run.angle_rad.push_back((angle_deg[i] + offset) * deg);
  }
  validate_dbb_run(run);
  return run;
}

DbbRun read_dbb_run(const std::string& path) {
  std::string text;
  try {
    text = read_text_file(path);  // a regular file within the input limits (core/input_file.hpp)
  } catch (const CsvError& e) {
    throw DbbRunFormatError(e.what());
  }
  if (is_raw_recording_text(text)) {  // the session's recording, not its runs: name the run files beside it
    std::vector<std::string> runs;
    for (const auto& d : derived_files(path)) {
      const std::string stem = d.substr(0, d.size() - 4);  // NAME.runK of NAME.runK.csv
      const auto dot = stem.rfind(".run");
      if (dot != std::string::npos && dot + 4 < stem.size() &&
          stem.find_first_not_of("0123456789", dot + 4) == std::string::npos)
        runs.push_back(d);
    }
    throw DbbRunFormatError(
        raw_recording_refusal(path, runs, "DBB run files (" + std::string(dbb_run_format_id) + ")"));
  }
  return parse_dbb_run(text, path);
}

std::string format_dbb_run(const DbbRun& run) {
  std::ostringstream o;
  o << std::setprecision(10);
  auto meta = run.metadata;
  meta.erase("format");
  o << "# format = " << dbb_run_format_id << "\n";
  o << "# radius_mm = " << run.radius_m * 1e3 << "\n";
  o << "# height_mm = " << run.height_m * 1e3 << "\n";
  o << "# direction = " << (run.direction == DbbDirection::ccw ? "ccw" : "cw") << "\n";
  o << "# feed_mm_per_min = " << run.feed_m_per_s * 60e3 << "\n";
  o << "# plane = " << run.plane << "\n";
  for (const char* k : {"radius_mm", "height_mm", "direction", "feed_mm_per_min", "plane"}) meta.erase(k);
  if (run.data_arc_rad != 0) meta["data_arc_deg"] = shortest(run.data_arc_rad / deg);
  if (run.center_a_m != 0 || run.center_b_m != 0) {
    o << "# center_a_mm = " << run.center_a_m * 1e3 << "\n# center_b_mm = " << run.center_b_m * 1e3 << "\n";
    meta.erase("center_a_mm");
    meta.erase("center_b_mm");
  }
  for (const auto& [k, v] : meta) o << "# " << k << " = " << v << "\n";
  o << "t_s,angle_deg,dL_um";
  for (const auto& [name, values] : run.extra_columns) {
    if (values.size() != run.angle_rad.size())
      throw DbbRunFormatError(run.source + ": column " + name + " has " + std::to_string(values.size()) +
                              " values for " + std::to_string(run.angle_rad.size()) + " samples");
    o << ',' << name;
  }
  o << "\n";
  // Data rows with the fewest digits that read back to the same values: a run file identified
  // offline gives exactly the result the daemon computed from it.
  std::string rows;
  rows.reserve(run.angle_rad.size() * 48);
  for (std::size_t i = 0; i < run.angle_rad.size(); ++i) {
    append_shortest(rows, run.t_s[i]);
    rows += ',';
    append_shortest(rows, run.angle_rad[i] / deg);
    rows += ',';
    append_shortest(rows, run.dL_m[i] * 1e6);
    for (const auto& column : run.extra_columns) {
      rows += ',';
      append_shortest(rows, column.second[i]);
    }
    rows += '\n';
  }
  return o.str() + rows;
}

void write_dbb_run(const DbbRun& run, const std::string& path) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw DbbRunFormatError(path + ": cannot open for writing: " + std::strerror(errno));
  out << format_dbb_run(run);
  out.flush();
  if (!out) {
    const int err = errno;
    out.close();
    std::remove(path.c_str());  // a truncated run would read as a shorter, wrong one
    throw DbbRunFormatError(path + ": write failed: " + std::strerror(err));
  }
}

}  // namespace guideway::formats
