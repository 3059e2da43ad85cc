// Surface-plate flatness by the Union Jack method (union_jack.hpp; Moody 1955): eight lines of readings made one
// surface.
#include "models/flatness/union_jack.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

#include <Eigen/Dense>

#include "core/number_format.hpp"
#include "models/flatness/minimum_zone.hpp"
#include "core/csv_table.hpp"

namespace guideway::models::flatness {

namespace {

std::string trimmed(std::string_view s) {
  const auto a = s.find_first_not_of(" \t\r");
  if (a == std::string_view::npos) return {};
  return std::string(s.substr(a, s.find_last_not_of(" \t\r") - a + 1).substr(0, 200));
}

// The lines of `text` (views into it), at most the input limit's rows (core/input_file.hpp).
std::vector<std::string_view> lines_of(const std::string& text, const std::string& path) {
  std::vector<std::string_view> out;
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t nl = text.find('\n', pos);
    out.push_back(std::string_view(text).substr(pos, nl == std::string::npos ? std::string::npos : nl - pos));
    pos = nl == std::string::npos ? text.size() : nl + 1;
    check_row_count(out.size(), path, out.size());
  }
  return out;
}

std::string join_path(const std::string& dir, const std::string& name) {
  if (dir.empty()) return name;
  return dir.back() == '/' ? dir + name : dir + "/" + name;
}

double read_foot_spacing(const std::string& dir, bool& inch) {
  const std::string path = join_path(dir, "Config.txt");
  const std::string text = read_text_file(path);
  const auto lines = lines_of(text, path);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string l = trimmed(lines[i]);
    if (l.empty() || l.front() == '#') continue;
    const std::string where = path + ":" + std::to_string(i + 1) + ": ";
    const char unit = l.front();
    const auto value = l.size() > 1 ? parse_double(std::string_view(l).substr(1)) : std::nullopt;
    if ((unit != 'I' && unit != 'M') || !value || !(*value > 0))
      throw CsvError(where + "expected 'I <inches>' or 'M <mm>' (the reflector foot spacing), got '" + l + "'");
    inch = unit == 'I';
    const double spacing_m = inch ? *value * metres_per_inch : *value * 1e-3;
    if (spacing_m > union_jack_max_foot_spacing_m)
      throw CsvError(where + "foot spacing " + l.substr(2) + (inch ? " in" : " mm") +
                     " is over 1000 mm, a reflector's base");
    return spacing_m;
  }
  throw CsvError(path + ": no foot spacing line ('I <inches>' or 'M <mm>')");
}

// Heights along one line from its readings: c_0 = 0, c_{j+1} = c_j + s tan(theta_j).
std::vector<double> cumulate(const std::vector<double>& angle_rad, double s) {
  std::vector<double> c(angle_rad.size() + 1, 0.0);
  for (std::size_t j = 0; j < angle_rad.size(); ++j) c[j + 1] = c[j] + s * std::tan(angle_rad[j]);
  return c;
}

// Moody's linear correction: the line is tilted so that it starts at h0 and ends at h1.
std::vector<double> fit_ends(const std::vector<double>& c, double h0, double h1) {
  const std::size_t n = c.size() - 1;
  std::vector<double> h(c.size());
  for (std::size_t j = 0; j <= n; ++j)
    h[j] = c[j] + h0 + (h1 - h0 - c[n]) * static_cast<double>(j) / static_cast<double>(n);
  return h;
}

struct Geometry {
  double x0, y0, x1, y1;
};

}  // namespace

UnionJackSet read_union_jack(const std::string& dir, double foot_spacing_override_m, const Autocollimator& ac) {
  UnionJackSet set;
  set.dir = dir;
  if (foot_spacing_override_m > 0) {
    set.foot_spacing_m = foot_spacing_override_m;
  } else {
    set.foot_spacing_m = read_foot_spacing(dir, set.inch_units);
  }
  std::array<std::size_t, 8> last_line{};
  const double range_arcsec = ac.range_rad / rad_per_arcsec;
  for (std::size_t i = 0; i < 8; ++i) {
    const std::string path = join_path(dir, std::string(union_jack_names[i]) + ".txt");
    const std::string text = read_text_file(path);
    const auto lines = lines_of(text, path);
    for (std::size_t k = 0; k < lines.size(); ++k) {
      const std::string l = trimmed(lines[k]);
      if (l.empty() || l.front() == '#') continue;
      const std::string where = path + ":" + std::to_string(k + 1) + ": ";
      const auto v = parse_double(l);
      if (!v) throw CsvError(where + "'" + l + "' is not a number (one reading in arc-seconds per line)");
      if (std::abs(*v) > range_arcsec)
        throw CsvError(where + "reading " + significant_digits(*v, 10) + " arcsec is outside the autocollimator range +-" +
                         significant_digits(range_arcsec, 10) + " arcsec");
      if (set.angle_rad[i].size() == union_jack_max_readings)
        throw CsvError(where + "more than " + std::to_string(union_jack_max_readings) +
                       " readings on a line (the evaluation's dense matrices grow with their square)");
      set.angle_rad[i].push_back(*v * rad_per_arcsec);
      set.file_line[i].push_back(k + 1);
      last_line[i] = k + 1;
    }
    if (set.angle_rad[i].size() < 2)
      throw CsvError(path + ": " + std::to_string(set.angle_rad[i].size()) + " readings; a line needs at least 2");
  }
  // Geometry: lines that must have equal numbers of readings, and even counts (the centre lines and
  // the diagonals cross at middle stations).
  const std::array<std::array<int, 3>, 3> groups = {{{2, 4, 6}, {3, 5, 7}, {0, 1, -1}}};
  const std::array<const char*, 3> what = {"the east-west lines NE_NW, SE_SW and E_W",
                                           "the north-south lines NE_SE, NW_SW and N_S",
                                           "the diagonals NW_SE and NE_SW"};
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const auto first = static_cast<std::size_t>(groups[g][0]);
    const std::size_t n = set.angle_rad[first].size();
    for (int idx : groups[g]) {
      if (idx < 0) continue;
      const auto i = static_cast<std::size_t>(idx);
      const std::string path = join_path(dir, std::string(union_jack_names[i]) + ".txt");
      if (set.angle_rad[i].size() != n)
        throw CsvError(path + ":" + std::to_string(last_line[i]) + ": " + std::to_string(set.angle_rad[i].size()) +
                         " readings, but " + union_jack_names[first] + ".txt has " + std::to_string(n) + " (" +
                         what[g] + " must have the same number of readings)");
      if (n % 2 != 0)
        throw CsvError(path + ":" + std::to_string(last_line[i]) + ": " + std::to_string(n) +
                         " readings: the Union Jack needs an even number on every line (the lines cross at their "
                         "middle stations)");
    }
  }
  return set;
}

namespace {

// The Moody heights of the eight lines: the diagonals with equal ends and the middle at zero, the sides
// fitted to the diagonals' corners, the centre lines to the sides' middles (their misclosure at the
// centre in `closure`).
std::array<std::vector<double>, 8> moody_heights(const UnionJackSet& set,
                                                 std::array<std::optional<double>, 8>& closure) {
  const double s = set.foot_spacing_m;
  const std::size_t nl = set.angle_rad[2].size(), ns = set.angle_rad[3].size(), nd = set.angle_rad[0].size();
  std::array<std::vector<double>, 8> h;
  for (std::size_t i = 0; i < 2; ++i) {
    h[i] = fit_ends(cumulate(set.angle_rad[i], s), 0.0, 0.0);
    const double mid = h[i][nd / 2];
    for (double& v : h[i]) v -= mid;
  }
  const double nw = h[0].front(), se = h[0].back(), ne = h[1].front(), sw = h[1].back();
  h[2] = fit_ends(cumulate(set.angle_rad[2], s), ne, nw);
  h[3] = fit_ends(cumulate(set.angle_rad[3], s), ne, se);
  h[4] = fit_ends(cumulate(set.angle_rad[4], s), se, sw);
  h[5] = fit_ends(cumulate(set.angle_rad[5], s), nw, sw);
  h[6] = fit_ends(cumulate(set.angle_rad[6], s), h[3][ns / 2], h[5][ns / 2]);
  h[7] = fit_ends(cumulate(set.angle_rad[7], s), h[2][nl / 2], h[4][nl / 2]);
  closure[6] = h[6][nl / 2];
  closure[7] = h[7][ns / 2];
  for (std::size_t i = 6; i < 8; ++i)
    for (double& v : h[i]) v -= *closure[i];
  return h;
}

// Peak to valley of the stations' heights about their least-squares plane, and their minimum zone.
void plane_flatness(const std::vector<UnionJackStation>& all, UnionJackResult& r) {
  Eigen::MatrixXd a(static_cast<Eigen::Index>(all.size()), 3);
  Eigen::VectorXd y(static_cast<Eigen::Index>(all.size()));
  for (std::size_t k = 0; k < all.size(); ++k) {
    const auto kk = static_cast<Eigen::Index>(k);
    a.row(kk) << 1.0, all[k].x_steps, all[k].y_steps;
    y(kk) = all[k].height_m;
  }
  const Eigen::VectorXd res = y - a * a.colPivHouseholderQr().solve(y);
  r.flatness_lsq_plane_m = res.maxCoeff() - res.minCoeff();
  std::vector<double> xs, ys, zs;
  for (const auto& st : all) xs.push_back(st.x_steps), ys.push_back(st.y_steps), zs.push_back(st.height_m);
  r.flatness_min_zone_m = minimum_zone_flatness(xs, ys, zs).width;
}

// All eight lines together by least squares: unknowns the unique stations' heights and an angular offset
// per line; the gauge (a constant and two tilts) removed by taking out the heights' least-squares plane.
UnionJackLsq least_squares_lines(const UnionJackSet& set, const UnionJackResult& r, const UnionJackOptions& options) {
  const double s = set.foot_spacing_m;
  UnionJackLsq lsq;
  // Unique stations keyed by coordinates (in 1e-6 station units).
  std::map<std::pair<long long, long long>, std::size_t> index;
  std::array<std::vector<std::size_t>, 8> station_of;
  for (std::size_t i = 0; i < 8; ++i) {
    for (const auto& st : r.lines[i].stations) {
      const std::pair<long long, long long> key{std::llround(st.x_steps * 1e6), std::llround(st.y_steps * 1e6)};
      auto [it, inserted] = index.emplace(key, lsq.stations.size());
      if (inserted) lsq.stations.push_back({st.x_steps, st.y_steps, 0.0});
      station_of[i].push_back(it->second);
    }
  }
  const std::size_t u = lsq.stations.size();
  std::size_t m = 0;
  for (const auto& a : set.angle_rad) m += a.size();
  // Unknowns: station heights (m), then per line an offset times the foot spacing (m).
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(u + 8));
  Eigen::VectorXd y(static_cast<Eigen::Index>(m));
  std::size_t row = 0;
  for (std::size_t i = 0; i < 8; ++i) {
    for (std::size_t j = 0; j < set.angle_rad[i].size(); ++j, ++row) {
      const auto rr = static_cast<Eigen::Index>(row);
      a(rr, static_cast<Eigen::Index>(station_of[i][j + 1])) += 1.0;
      a(rr, static_cast<Eigen::Index>(station_of[i][j])) -= 1.0;
      a(rr, static_cast<Eigen::Index>(u + i)) = -1.0;
      y(rr) = s * std::tan(set.angle_rad[i][j]);
    }
  }
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(a);
  cod.setThreshold(1e-10);
  const Eigen::VectorXd x = cod.solve(y);
  const Eigen::MatrixXd pinv = cod.pseudoInverse();
  Eigen::MatrixXd plane(static_cast<Eigen::Index>(u), 3);
  for (std::size_t k = 0; k < u; ++k)
    plane.row(static_cast<Eigen::Index>(k)) << 1.0, lsq.stations[k].x_steps, lsq.stations[k].y_steps;
  const Eigen::MatrixXd proj = Eigen::MatrixXd::Identity(static_cast<Eigen::Index>(u), static_cast<Eigen::Index>(u)) -
                               plane * (plane.transpose() * plane).inverse() * plane.transpose();
  const Eigen::VectorXd heights = proj * x.head(static_cast<Eigen::Index>(u));
  const Eigen::MatrixXd sens = proj * pinv.topRows(static_cast<Eigen::Index>(u));
  const double su = s * options.instrument.reading_u_rad();
  lsq.u_height_m.resize(u);
  for (std::size_t k = 0; k < u; ++k) {
    lsq.stations[k].height_m = heights(static_cast<Eigen::Index>(k));
    lsq.u_height_m[k] = su * sens.row(static_cast<Eigen::Index>(k)).norm();
  }
  for (std::size_t i = 0; i < 8; ++i) lsq.offset_rad[i] = x(static_cast<Eigen::Index>(u + i)) / s;
  const Eigen::VectorXd res = y - a * x;
  lsq.residual_rms_rad = std::sqrt(res.squaredNorm() / static_cast<double>(m)) / s;
  lsq.readings = m;
  lsq.unknowns = u + 8;
  lsq.redundancy = m - static_cast<std::size_t>(cod.rank());
  lsq.flatness_m = heights.maxCoeff() - heights.minCoeff();
  std::vector<double> xs, ys, zs;
  for (const auto& st : lsq.stations) xs.push_back(st.x_steps), ys.push_back(st.y_steps), zs.push_back(st.height_m);
  lsq.flatness_min_zone_m = minimum_zone_flatness(xs, ys, zs).width;
  return lsq;
}

}  // namespace

UnionJackResult evaluate_union_jack(const UnionJackSet& set, const UnionJackOptions& options) {
  UnionJackResult r;
  r.foot_spacing_m = set.foot_spacing_m;
  const std::size_t nl = set.angle_rad[2].size(), ns = set.angle_rad[3].size(), nd = set.angle_rad[0].size();
  r.long_steps = nl;
  r.short_steps = ns;
  r.diagonal_steps = nd;
  const auto dl = static_cast<double>(nl), ds = static_cast<double>(ns), dd = static_cast<double>(nd);
  if (std::abs(std::hypot(dl, ds) - dd) > 1.5)
    r.warnings.push_back("the diagonals have " + std::to_string(nd) + " readings, far from sqrt(" + std::to_string(nl) +
                         "^2 + " + std::to_string(ns) + "^2) = " + significant_digits(std::hypot(dl, ds), 10));
  // Start and end of each line in station units (SW corner at 0, 0; x east, y north).
  const std::array<Geometry, 8> geo = {{{0, ds, dl, 0},             // NW_SE
                                        {dl, ds, 0, 0},             // NE_SW
                                        {dl, ds, 0, ds},            // NE_NW
                                        {dl, ds, dl, 0},            // NE_SE
                                        {dl, 0, 0, 0},              // SE_SW
                                        {0, ds, 0, 0},              // NW_SW
                                        {dl, ds / 2, 0, ds / 2},    // E_W
                                        {dl / 2, ds, dl / 2, 0}}};  // N_S
  std::array<std::optional<double>, 8> closure{};
  const std::array<std::vector<double>, 8> h = moody_heights(set, closure);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& line : h)
    for (double v : line) lo = std::min(lo, v), hi = std::max(hi, v);
  r.flatness_m = hi - lo;
  std::vector<UnionJackStation> all;
  for (std::size_t i = 0; i < 8; ++i) {
    auto& out = r.lines[i];
    out.name = union_jack_names[i];
    out.closure_m = closure[i];
    const std::size_t n = h[i].size() - 1;
    for (std::size_t j = 0; j <= n; ++j) {
      const double f = static_cast<double>(j) / static_cast<double>(n);
      UnionJackStation st{geo[i].x0 + (geo[i].x1 - geo[i].x0) * f, geo[i].y0 + (geo[i].y1 - geo[i].y0) * f,
                          h[i][j] - lo};
      out.stations.push_back(st);
      all.push_back(st);
    }
  }
  plane_flatness(all, r);
  if (options.least_squares) r.lsq = least_squares_lines(set, r, options);
  return r;
}

}  // namespace guideway::models::flatness
