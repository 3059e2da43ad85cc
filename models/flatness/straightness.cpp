// Straightness from an autocollimator traverse or a slope profile (straightness.hpp): slopes integrated, LS and end-
// point lines.
#include "models/flatness/straightness.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>

#include "core/csv_table.hpp"
#include "core/number_format.hpp"
#include "formats/dabam.hpp"
#include "models/flatness/instruments.hpp"

namespace guideway::models::flatness {

namespace {

std::string where(const std::string& source, std::size_t line) { return source + ":" + std::to_string(line) + ": "; }

// Sum of squares of sensitivities of a quantity to the readings; the quantity's standard uncertainty
// is step * u_theta * sqrt(sum). `row(j)` is d quantity / d (step * theta_j).
template <class Row>
double row_norm2(std::size_t n, Row&& row) {
  double s = 0.0;
  for (std::size_t j = 0; j < n; ++j) {
    const double r = row(j);
    s += r * r;
  }
  return s;
}

// Cumulative-sum sensitivity: height of station k depends on readings j < k.
double c_row(std::size_t k, std::size_t j) { return j < k ? 1.0 : 0.0; }

void fill_range(ReferenceLine& r) {
  const auto [mn, mx] = std::minmax_element(r.deviation_m.begin(), r.deviation_m.end());
  r.min_index = static_cast<std::size_t>(mn - r.deviation_m.begin());
  r.max_index = static_cast<std::size_t>(mx - r.deviation_m.begin());
  r.straightness_m = *mx - *mn;
}

// `t`: each station's position in steps from the first (t_k = k on the grid), N = n + 1 of them.
PolynomialFit fit_polynomial(double step_m, const std::vector<double>& t, const std::vector<double>& angle_rad,
                             const std::vector<double>& height_m, double u_angle_rad, int max_order) {
  const std::size_t n = angle_rad.size();
  const double span_steps = t[n];
  const double span = step_m * span_steps;
  Eigen::VectorXd y(static_cast<Eigen::Index>(n));
  for (std::size_t j = 0; j < n; ++j) y(static_cast<Eigen::Index>(j)) = std::tan(angle_rad[j]);
  const int highest = std::max(1, std::min(max_order, static_cast<int>(n) - 2));
  const double rss_floor = static_cast<double>(n) * std::pow(1e-6 * u_angle_rad, 2);
  const double dn = static_cast<double>(n);

  // Chord slope of reading r in the scaled coordinate xi = (x - x0) / span: (p(xi_r+1) - p(xi_r)) / sigma_r.
  auto design = [&](int order) {
    Eigen::MatrixXd j(static_cast<Eigen::Index>(n), order);
    for (std::size_t r = 0; r < n; ++r) {
      const double xi = t[r] / span_steps, xi1 = t[r + 1] / span_steps, sigma = xi1 - xi;
      for (int k = 1; k <= order; ++k)
        j(static_cast<Eigen::Index>(r), k - 1) = (std::pow(xi1, k) - std::pow(xi, k)) / sigma;
    }
    return j;
  };

  PolynomialFit fit;
  int best = 1;
  double best_bic = std::numeric_limits<double>::infinity();
  for (int order = 1; order <= highest; ++order) {
    const Eigen::MatrixXd j = design(order);
    const Eigen::VectorXd c = j.colPivHouseholderQr().solve(y);
    const double rss = (y - j * c).squaredNorm();
    const double bic = dn * std::log(std::max(rss, rss_floor) / dn) + order * std::log(dn);
    fit.bic.push_back(bic);
    if (bic < best_bic - 1e-9) {
      best_bic = bic;
      best = order;
    }
  }
  const Eigen::MatrixXd j = design(best);
  const Eigen::VectorXd c = j.colPivHouseholderQr().solve(y);
  const Eigen::VectorXd res = y - j * c;
  const double dof = dn - best;
  const double s2 = dof > 0 ? res.squaredNorm() / dof : u_angle_rad * u_angle_rad;
  const Eigen::MatrixXd cov = s2 * (j.transpose() * j).inverse();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(j);
  const auto& sv = svd.singularValues();
  fit.condition_number = sv(sv.size() - 1) > 0 ? sv(0) / sv(sv.size() - 1) : std::numeric_limits<double>::infinity();
  fit.order = best;
  fit.b.assign(static_cast<std::size_t>(best) + 1, 0.0);
  fit.u_b.assign(static_cast<std::size_t>(best) + 1, 0.0);
  for (int k = 1; k <= best; ++k) {
    const double scale = std::pow(span, k - 1);
    fit.b[static_cast<std::size_t>(k)] = c(k - 1) / scale;
    fit.u_b[static_cast<std::size_t>(k)] = std::sqrt(cov(k - 1, k - 1)) / scale;
  }
  fit.angle_residual_rms_rad = std::sqrt(res.squaredNorm() / dn);
  fit.residual_m.resize(height_m.size());
  double ss = 0.0;
  for (std::size_t k = 0; k < height_m.size(); ++k) {
    fit.residual_m[k] = height_m[k] - fit(step_m * t[k]);
    ss += fit.residual_m[k] * fit.residual_m[k];
    fit.residual_max_m = std::max(fit.residual_max_m, std::abs(fit.residual_m[k]));
  }
  fit.residual_rms_m = std::sqrt(ss / static_cast<double>(height_m.size()));
  return fit;
}

// The three straightness values of chord-slope angles (no uncertainties): for the bootstrap. `t`: the
// stations in steps (fit_polynomial), `ds` each reading's spacing in m.
std::array<double, 3> straightness_values(const std::vector<double>& angle_rad, const std::vector<double>& ds,
                                          const std::vector<double>& t, std::vector<double>& h) {
  const std::size_t n = angle_rad.size();
  h.assign(n + 1, 0.0);
  for (std::size_t k = 0; k < n; ++k) h[k + 1] = h[k] + ds[k] * std::tan(angle_rad[k]);
  const double dN = static_cast<double>(n + 1);
  double lo_e = 0, hi_e = 0, ybar = 0, tbar = 0, sxx = 0, sxy = 0;
  for (std::size_t k = 0; k <= n; ++k) {
    const double d = h[k] - t[k] / t[n] * h[n];
    lo_e = std::min(lo_e, d), hi_e = std::max(hi_e, d);
    ybar += h[k] / dN;
    tbar += t[k] / dN;
  }
  for (std::size_t k = 0; k <= n; ++k) sxx += (t[k] - tbar) * (t[k] - tbar), sxy += (t[k] - tbar) * (h[k] - ybar);
  double lo_l = std::numeric_limits<double>::infinity(), hi_l = -lo_l;
  for (std::size_t k = 0; k <= n; ++k) {
    const double d = h[k] - ybar - sxy / sxx * (t[k] - tbar);
    lo_l = std::min(lo_l, d), hi_l = std::max(hi_l, d);
  }
  return {hi_e - lo_e, hi_l - lo_l, minimum_zone(t, h).width};
}

}  // namespace

double PolynomialFit::operator()(double x) const {
  double v = 0.0;
  for (std::size_t k = b.size(); k-- > 0;) v = v * x + b[k];
  return v;
}

double PolynomialFit::slope(double x) const {
  double v = 0.0;
  for (std::size_t k = b.size(); k-- > 1;) v = v * x + static_cast<double>(k) * b[k];
  return v;
}

double traverse_step_mm(const CsvTable& t) {
  return t.metadata_in("step_mm", traverse_min_step_mm, traverse_max_step_mm, "mm, a reflector's foot spacing");
}

double traverse_x_mm(const CsvTable& t, const CsvTable::Row& row, std::size_t col) {
  return t.number_in(row, col, -traverse_max_abs_x_mm, traverse_max_abs_x_mm, "mm, a machine's travel");
}

double traverse_angle_rad(const CsvTable& t, const CsvTable::Row& row, std::size_t col) {
  const double arcsec = t.number(row, col);
  if (!(std::abs(arcsec) * rad_per_arcsec <= max_abs_angle_rad))
    throw CsvError(where(t.source, row.line) + t.columns[col] + " = " + significant_digits(arcsec, 10) +
                   " is outside +-" + significant_digits(max_abs_angle_rad / rad_per_arcsec, 6) +
                   " arcsec (a slope's plausible bound)");
  return arcsec * rad_per_arcsec;
}

double traverse_time_s(const CsvTable& t, const CsvTable::Row& row, std::size_t col) {
  return t.number_in(row, col, -traverse_max_abs_t_s, traverse_max_abs_t_s, "s, one file's clock (116 days)");
}

double traverse_pass(const CsvTable& t, const CsvTable::Row& row, std::size_t col) {
  const double n = t.number(row, col);
  if (!(n >= 1 && n <= traverse_max_pass && n == std::floor(n)))
    throw CsvError(where(t.source, row.line) + t.columns[col] + " = " + significant_digits(n, 10) +
                   " is not a pass number (a whole number in [1, " + significant_digits(traverse_max_pass, 10) + "])");
  return n;
}

AngleTraverse parse_angle_traverse(std::string_view text, const std::string& source, const Autocollimator& ac) {
  const CsvTable t = parse_csv_table(text, source);
  AngleTraverse tr;
  tr.source = source;
  tr.instrument = ac;
  const double step_mm = traverse_step_mm(t);
  tr.step_m = step_mm * 1e-3;
  const std::size_t cx = t.column("x_mm");
  const std::size_t cp = t.column("pitch_arcsec");
  const auto cy = t.find_column("yaw_arcsec");
  // A file of several passes (a `pass` column): its first pass is the traverse evaluated here.
  std::size_t rows = t.rows.size();
  if (const auto cpass = t.find_column("pass"); cpass && rows > 0) {
    const double first = traverse_pass(t, t.rows.front(), *cpass);
    for (std::size_t i = 1; i < rows; ++i)
      if (traverse_pass(t, t.rows[i], *cpass) != first) {
        rows = i;
        break;
      }
  }
  if (rows < 2) throw CsvError(source + ": " + std::to_string(rows) + " readings; a traverse needs at least 2");
  double prev_x = 0.0;
  for (std::size_t i = 0; i < rows; ++i) {
    const auto& row = t.rows[i];
    if (i == traverse_max_readings)  // here, not before: an earlier line at fault is named first
      throw CsvError(where(source, row.line) + "more than " + std::to_string(traverse_max_readings) +
                     " readings in a pass (the straightness session's most)");
    const double x = traverse_x_mm(t, row, cx);
    if (i > 0) {
      const double dx = x - prev_x;
      const double tol = station_jitter_tolerance * step_mm;
      if (dx <= tol)
        throw CsvError(where(source, row.line) + "x_mm = " + significant_digits(x, 10) +
                       " does not increase (previous station " + significant_digits(prev_x, 10) + ")");
      if (std::abs(dx - step_mm) > tol) {
        const double steps = dx / step_mm;
        if (std::abs(steps - std::round(steps)) <= station_jitter_tolerance)
          throw CsvError(where(source, row.line) + "missing station: x_mm jumps from " +
                         significant_digits(prev_x, 10) + " to " + significant_digits(x, 10) + " (step_mm = " +
                         significant_digits(step_mm, 10) + ", " + significant_digits(std::round(steps) - 1, 10) +
                         " station(s) missing, first at x_mm = " + significant_digits(prev_x + step_mm, 10) + ")");
        throw CsvError(where(source, row.line) + "x_mm spacing " + significant_digits(dx, 10) + " is not within " +
                       significant_digits(100 * station_jitter_tolerance, 3) + " % of step_mm = " +
                       significant_digits(step_mm, 10) + " (positions that jitter by less are used as measured)");
      }
      if (const double off = std::abs(dx - step_mm) / step_mm; off > station_grid_tolerance)
        tr.jitter = std::max(tr.jitter, off);
    }
    prev_x = x;
    tr.x_m.push_back(x * 1e-3);
    tr.pitch_rad.push_back(traverse_angle_rad(t, row, cp));
    if (cy) tr.yaw_rad.push_back(traverse_angle_rad(t, row, *cy));
    tr.line.push_back(row.line);
  }
  check_instrument_range(tr.pitch_rad, ac, t.columns[cp], source, tr.line);
  if (cy) check_instrument_range(tr.yaw_rad, ac, t.columns[*cy], source, tr.line);
  return tr;
}

AngleTraverse slope_profile_traverse(const std::string& source, const std::vector<double>& x_m,
                                     const std::vector<double>& slope_rad, const std::vector<std::size_t>& lines,
                                     const Autocollimator& ac) {
  const std::size_t n = x_m.size();
  if (n < 2 || slope_rad.size() != n)
    throw CsvError(source + ": " + std::to_string(n) + " reading(s); a profile needs at least 2, one slope each");
  const auto line = [&](std::size_t i) { return i < lines.size() ? where(source, lines[i]) : source + ": "; };
  std::vector<double> dx(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) dx[i] = x_m[i + 1] - x_m[i];
  std::vector<double> sorted = dx;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double step = sorted[sorted.size() / 2];
  if (!(step > 0)) throw CsvError(source + ": positions do not increase");
  AngleTraverse tr;
  tr.source = source;
  tr.instrument = ac;
  tr.step_m = step;
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0) {
      const double off = std::abs(dx[i - 1] - step) / step;
      if (off > station_jitter_tolerance)
        throw CsvError(line(i) + "spacing " + significant_digits(dx[i - 1] * 1e3, 8) + " mm after " +
                       significant_digits(x_m[i - 1] * 1e3, 10) + " mm is not within " +
                       significant_digits(100 * station_jitter_tolerance, 3) + " % of the profile's step " +
                       significant_digits(step * 1e3, 8) + " mm (the median spacing): a gap or a change of step");
      if (off > station_grid_tolerance) tr.jitter = std::max(tr.jitter, off);
    }
    if (!(std::abs(slope_rad[i]) <= max_abs_angle_rad))
      throw CsvError(line(i) + "slope " + significant_digits(slope_rad[i], 8) + " rad is outside +-" +
                     significant_digits(max_abs_angle_rad, 3) + " rad (a slope's plausible bound)");
    tr.x_m.push_back(x_m[i] - step / 2);
    tr.pitch_rad.push_back(std::atan(slope_rad[i]));
    tr.line.push_back(i < lines.size() ? lines[i] : 0);
  }
  check_instrument_range(tr.pitch_rad, ac, "slope", source, lines);
  return tr;
}

Autocollimator default_instrument(const std::string& path) {
  return instrument_profile(formats::is_dabam_path(path) ? "deflectometer" : "autocollimator");
}

AngleTraverse read_angle_traverse(const std::string& path, const Autocollimator& ac) {
  if (formats::is_dabam_path(path)) {
    const formats::DabamProfile d = formats::read_dabam(path);
    return slope_profile_traverse(d.source, d.x_m, d.slope_rad, d.line, ac);
  }
  return parse_angle_traverse(read_text_file(path), path, ac);
}

MinimumZone minimum_zone(const std::vector<double>& x, const std::vector<double>& y) {
  MinimumZone best;
  const std::size_t n = x.size();
  if (n == 0 || y.size() != n) throw std::invalid_argument("minimum_zone: need matching, non-empty x and y");
  if (n == 1) return {0.0, 0.0, y[0]};
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return x[a] < x[b] || (x[a] == x[b] && y[a] < y[b]); });
  auto cross = [&](std::size_t o, std::size_t a, std::size_t b) {
    return (x[a] - x[o]) * (y[b] - y[o]) - (y[a] - y[o]) * (x[b] - x[o]);
  };
  // Andrew's monotone chain: lower hull (counter-clockwise turns) and upper hull.
  std::vector<std::size_t> lower, upper;
  for (std::size_t i : order) {
    while (lower.size() >= 2 && cross(lower[lower.size() - 2], lower.back(), i) <= 0) lower.pop_back();
    lower.push_back(i);
  }
  for (auto it = order.rbegin(); it != order.rend(); ++it) {
    while (upper.size() >= 2 && cross(upper[upper.size() - 2], upper.back(), *it) <= 0) upper.pop_back();
    upper.push_back(*it);
  }
  // Both chains left to right: the lower's edge slopes increase, the upper's decrease. The extreme of
  // y - m x over all points (max for a lower edge, min for an upper one) lies on the other chain, at the
  // first vertex whose next edge turns past m: a binary search, so a curved profile whose hull holds every
  // station costs O(n log n), not O(n^2).
  std::reverse(upper.begin(), upper.end());
  // slope(a, b) > m for a left of b, without dividing (a vertical edge's slope is +-inf).
  auto steeper = [&](std::size_t a, std::size_t b, double m) { return y[b] - y[a] > m * (x[b] - x[a]); };
  auto extreme_on = [&](const std::vector<std::size_t>& chain, double m, bool max) {
    std::size_t lo = 0, hi = chain.size() - 1;  // first vertex i with edge (i, i+1) past m; hi: the last
    while (lo < hi) {
      const std::size_t mid = (lo + hi) / 2;
      const bool past = max ? !steeper(chain[mid], chain[mid + 1], m) : steeper(chain[mid], chain[mid + 1], m);
      if (past)
        hi = mid;
      else
        lo = mid + 1;
    }
    return y[chain[lo]] - m * x[chain[lo]];
  };
  best.width = std::numeric_limits<double>::infinity();
  auto try_edge = [&](std::size_t a, std::size_t b, bool on_lower) {
    if (x[a] == x[b]) return;  // vertical edge: not a candidate direction for a vertical zone
    const double m = (y[b] - y[a]) / (x[b] - x[a]);
    const double c_edge = y[a] - m * x[a];
    const double other = extreme_on(on_lower ? upper : lower, m, on_lower);
    const double extreme = on_lower ? std::max(c_edge, other) : std::min(c_edge, other);
    const double w = std::abs(extreme - c_edge);
    if (w < best.width) best = {w, m, on_lower ? c_edge : extreme};
  };
  for (std::size_t i = 0; i + 1 < lower.size(); ++i) try_edge(lower[i], lower[i + 1], true);
  for (std::size_t i = 0; i + 1 < upper.size(); ++i) try_edge(upper[i], upper[i + 1], false);
  if (!std::isfinite(best.width))
    best = {*std::max_element(y.begin(), y.end()) - *std::min_element(y.begin(), y.end()), 0.0,
            *std::min_element(y.begin(), y.end())};
  return best;
}

namespace {

// End-point line: d_k = h_k - (t_k/t_n) h_n. Brownian bridge (on the grid): var d_k = (s u)^2 k (n-k)/n,
// var(d_a - d_b) = (s u)^2 m (n-m)/n with m = |a - b|.
void end_point_line(StraightnessProfile& p, const std::vector<double>& t, std::size_t n, double s, double su) {
  const std::size_t N = n + 1;
  const double dn = static_cast<double>(n);
  auto& r = p.end_point;
  r.slope = (p.height_m[n] - p.height_m[0]) / (s * t[n]);
  r.intercept_m = 0.0;
  r.deviation_m.resize(N);
  r.u_deviation_m.resize(N);
  for (std::size_t k = 0; k < N; ++k) {
    const double dk = static_cast<double>(k);
    r.deviation_m[k] = p.height_m[k] - t[k] / t[n] * p.height_m[n];
    r.u_deviation_m[k] = su * std::sqrt(dk * (dn - dk) / dn);
  }
  fill_range(r);
  const double m = std::abs(static_cast<double>(r.max_index) - static_cast<double>(r.min_index));
  r.u_straightness_m = su * std::sqrt(m * (dn - m) / dn);
}

// Least-squares line through the N stations (in x; u on the grid, t_k = k): d = (I - H) C theta s, with the hat
// matrix H_km = 1/N + (t_k - tbar)(t_m - tbar)/Sxx and C_kj = [j < k]. Row k, column j:
// [j < k] - (n - j)/N - (k - tbar) S_j / Sxx, where S_j = sum_{m>j} (m - tbar).
void least_squares_line(StraightnessProfile& p, const std::vector<double>& t, std::size_t n, double s, double su) {
  const std::size_t N = n + 1;
  const double dn = static_cast<double>(n);
  auto& r = p.least_squares;
  const double dN = static_cast<double>(N);
  double sxx = 0.0, sxy = 0.0, ybar = 0.0, tmean = 0.0;
  for (std::size_t k = 0; k < N; ++k) ybar += p.height_m[k] / dN, tmean += t[k] / dN;
  for (std::size_t k = 0; k < N; ++k) {
    const double dt = t[k] - tmean;
    sxx += dt * dt;
    sxy += dt * (p.height_m[k] - ybar);
  }
  const double beta = sxy / sxx;  // per step
  r.slope = beta / s;
  r.intercept_m = ybar - beta * tmean;
  const double tbar = dn / 2.0;
  double gxx = 0.0;  // Sxx on the grid
  for (std::size_t k = 0; k < N; ++k) gxx += (static_cast<double>(k) - tbar) * (static_cast<double>(k) - tbar);
  std::vector<double> big_s(n);
  for (std::size_t j = 0; j < n; ++j) {
    // sum_{m=j+1}^{n} (m - tbar)
    const double cnt = dn - static_cast<double>(j);
    const double sum_m = (dn * (dn + 1) - static_cast<double>(j) * static_cast<double>(j + 1)) / 2.0;
    big_s[j] = sum_m - cnt * tbar;
  }
  auto ls_row = [&](std::size_t k, std::size_t j) {
    return c_row(k, j) - (dn - static_cast<double>(j)) / dN - (static_cast<double>(k) - tbar) * big_s[j] / gxx;
  };
  r.deviation_m.resize(N);
  r.u_deviation_m.resize(N);
  for (std::size_t k = 0; k < N; ++k) {
    r.deviation_m[k] = p.height_m[k] - (r.intercept_m + beta * t[k]);
    r.u_deviation_m[k] = su * std::sqrt(row_norm2(n, [&](std::size_t j) { return ls_row(k, j); }));
  }
  fill_range(r);
  r.u_straightness_m =
      su * std::sqrt(row_norm2(n, [&](std::size_t j) { return ls_row(r.max_index, j) - ls_row(r.min_index, j); }));
}

// Minimum zone: exact from the convex hull (in x). Its value is max - min of the deviations from the zone
// lines; first-order uncertainty through the stations that bound it (the extreme deviations from
// the lower line and the two stations of the hull edge, found as the points on the lower/upper line).
// After least_squares_line, whose u it falls back on.
void minimum_zone_line(StraightnessProfile& p, const std::vector<double>& t, std::size_t n, double s, double su) {
  const std::size_t N = n + 1;
  auto& r = p.minimum_zone;
  const MinimumZone mz = minimum_zone(t, p.height_m);
  r.slope = mz.slope / s;
  r.intercept_m = mz.lower_intercept;
  r.deviation_m.resize(N);
  r.u_deviation_m.assign(N, 0.0);
  for (std::size_t k = 0; k < N; ++k) r.deviation_m[k] = p.height_m[k] - (mz.lower_intercept + mz.slope * t[k]);
  fill_range(r);
  r.straightness_m = mz.width;
  // Contact stations: those within a tolerance of the lower and upper lines.
  const double tol = 1e-9 * std::max(mz.width, 1e-12) + 1e-15;
  std::vector<std::size_t> low, high;
  for (std::size_t k = 0; k < N; ++k) {
    if (r.deviation_m[k] <= tol) low.push_back(k);
    if (r.deviation_m[k] >= mz.width - tol) high.push_back(k);
  }
  // The line with two contacts carries the edge (a, b); the other contact c sets the width:
  // w = +-(h_c - h_a - (h_b - h_a)(c - a)/(b - a)).
  std::vector<std::size_t>& edge = low.size() >= 2 ? low : high;
  std::vector<std::size_t>& apex = low.size() >= 2 ? high : low;
  if (edge.size() >= 2 && !apex.empty()) {
    const std::size_t a = edge.front(), b = edge.back(), c = apex.front();
    const double lam =
        (static_cast<double>(c) - static_cast<double>(a)) / (static_cast<double>(b) - static_cast<double>(a));
    r.u_straightness_m = su * std::sqrt(row_norm2(n, [&](std::size_t j) {
                           return c_row(c, j) - (1 - lam) * c_row(a, j) - lam * c_row(b, j);
                         }));
  } else {
    r.u_straightness_m = p.least_squares.u_straightness_m;
  }
  for (std::size_t k = 0; k < N; ++k) r.u_deviation_m[k] = p.least_squares.u_deviation_m[k];
}

// Selection bias of the three max - min values: simulate the traverse of the fitted polynomial with
// angle noise u_angle, many times; bias = mean(simulated value) - value of the polynomial itself, at least
// 0 (noise only widens a max - min; a negative mean is the bootstrap's own scatter).
std::array<double, 3> bootstrap_bias(const StraightnessProfile& p, const std::vector<double>& t,
                                     const std::vector<double>& ds, double u_angle, int bootstrap) {
  const std::size_t n = ds.size();
  std::vector<double> proxy(n), noisy(n), h;
  for (std::size_t j = 0; j < n; ++j) {
    const double xj = p.x_m[j] - p.x_m[0];
    proxy[j] = std::atan((p.polynomial(xj + ds[j]) - p.polynomial(xj)) / ds[j]);
  }
  const auto reference = straightness_values(proxy, ds, t, h);
  std::mt19937_64 rng(0x5eed5eedULL + n);
  std::normal_distribution<double> noise(0.0, u_angle);
  std::array<double, 3> bias{};
  for (int i = 0; i < bootstrap; ++i) {
    for (std::size_t j = 0; j < n; ++j) noisy[j] = proxy[j] + noise(rng);
    const auto v = straightness_values(noisy, ds, t, h);
    for (std::size_t q = 0; q < 3; ++q) bias[q] += (v[q] - reference[q]) / bootstrap;
  }
  for (double& b : bias) b = std::max(0.0, b);
  return bias;
}

void selection_bias(StraightnessProfile& p, const std::vector<double>& t, const std::vector<double>& ds,
                    int bootstrap) {
  std::array<ReferenceLine*, 3> lines = {&p.end_point, &p.least_squares, &p.minimum_zone};
  for (auto* r : lines) r->u_first_order_m = r->u_straightness_m;
  if (bootstrap <= 0 || !(p.u_angle_rad > 0)) return;
  const auto bias = bootstrap_bias(p, t, ds, p.u_angle_rad, bootstrap);
  for (std::size_t q = 0; q < 3; ++q) {
    lines[q]->selection_bias_m = bias[q];
    lines[q]->u_straightness_m = std::hypot(lines[q]->u_first_order_m, bias[q]);
  }
  // The same with the readings' own scatter: the first-order u scales with the reading's u, the bias is
  // simulated anew.
  if (!(p.u_angle_data_rad > 0)) return;
  const auto data_bias = bootstrap_bias(p, t, ds, p.u_angle_data_rad, bootstrap);
  for (std::size_t q = 0; q < 3; ++q)
    lines[q]->u_straightness_data_m =
        std::hypot(lines[q]->u_first_order_m * p.u_angle_data_rad / p.u_angle_rad, data_bias[q]);
}

// The readings' scatter beside the instrument's u, and what to say when they disagree.
void data_scatter(StraightnessProfile& p, const std::vector<double>& angle_rad, const std::string& instrument) {
  const auto [lo, hi] = std::minmax_element(angle_rad.begin(), angle_rad.end());
  p.tilt_rad = (*hi + *lo) / 2;
  p.span_rad = *hi - *lo;
  p.u_angle_data_rad = reading_scatter_rad(angle_rad);
  if (!(p.u_angle_data_rad > 0) || !(p.u_angle_rad > 0)) return;
  const double ratio = p.u_angle_rad / p.u_angle_data_rad;
  if (ratio <= u_disagreement_factor && ratio >= 1 / u_disagreement_factor) return;
  const auto arcsec = [](double rad) { return significant_digits(rad / rad_per_arcsec, 3) + "\""; };
  p.u_disagreement = "the readings scatter " + arcsec(p.u_angle_data_rad) + " (finest wavelet details), " +
                     significant_digits(ratio > 1 ? ratio : 1 / ratio, 2) + "x " + (ratio > 1 ? "below" : "above") +
                     " the " + arcsec(p.u_angle_rad) + " stated for the " + instrument +
                     ": the u given is the instrument's, the data's beside it";
}

// Each reading's spacing from the rear feet (the last one's the step); a spacing within station_grid_tolerance
// of the step is the step (positions on the grid, as a file's decimal millimetres give them).
std::vector<double> spacing_of(const std::vector<double>& x_m, double step_m) {
  std::vector<double> ds(x_m.size(), step_m);
  for (std::size_t k = 0; k + 1 < x_m.size(); ++k)
    if (const double d = x_m[k + 1] - x_m[k]; std::abs(d - step_m) > station_grid_tolerance * step_m) ds[k] = d;
  return ds;
}

StraightnessProfile straightness_of(double x0_m, double step_m, const std::vector<double>& ds,
                                    const std::vector<double>& angle_rad, const StraightnessOptions& options,
                                    const std::string& plane) {
  const std::size_t n = angle_rad.size();
  if (n < 2) throw std::invalid_argument("straightness: need at least 2 readings");
  if (!(step_m > 0)) throw std::invalid_argument("straightness: step must be positive");
  StraightnessProfile p;
  p.plane = plane;
  p.u_angle_rad = options.instrument.reading_u_rad();
  const double s = step_m;
  const double su = s * p.u_angle_rad;
  const std::size_t N = n + 1;
  const bool grid = std::all_of(ds.begin(), ds.end(), [&](double d) { return d == s; });
  p.x_m.resize(N);
  p.height_m.resize(N);
  p.u_height_m.resize(N);
  std::vector<double> t(N);
  for (std::size_t k = 0; k < N; ++k) {
    p.x_m[k] = k == 0 ? x0_m : grid ? x0_m + s * static_cast<double>(k) : p.x_m[k - 1] + ds[k - 1];
    t[k] = grid ? static_cast<double>(k) : (p.x_m[k] - x0_m) / s;
    p.height_m[k] = k == 0 ? 0.0 : p.height_m[k - 1] + ds[k - 1] * std::tan(angle_rad[k - 1]);
    p.u_height_m[k] = su * std::sqrt(static_cast<double>(k));
  }
  end_point_line(p, t, n, s, su);
  least_squares_line(p, t, n, s, su);
  minimum_zone_line(p, t, n, s, su);
  p.polynomial = fit_polynomial(s, t, angle_rad, p.height_m, p.u_angle_rad, options.max_order);
  data_scatter(p, angle_rad, options.instrument.name);
  selection_bias(p, t, ds, options.bootstrap);
  return p;
}

}  // namespace

StraightnessProfile straightness_from_angles(double x0_m, double step_m, const std::vector<double>& angle_rad,
                                             const StraightnessOptions& options, const std::string& plane) {
  return straightness_of(x0_m, step_m, std::vector<double>(angle_rad.size(), step_m), angle_rad, options, plane);
}

StraightnessProfile straightness_from_stations(const std::vector<double>& x_m, double step_m,
                                               const std::vector<double>& angle_rad, const StraightnessOptions& options,
                                               const std::string& plane) {
  if (x_m.size() != angle_rad.size() || x_m.empty())
    throw std::invalid_argument("straightness: one rear-foot position per reading");
  return straightness_of(x_m.front(), step_m, spacing_of(x_m, step_m), angle_rad, options, plane);
}

StraightnessResult identify_straightness(const AngleTraverse& traverse, const StraightnessOptions& options) {
  StraightnessResult r;
  r.source = traverse.source;
  r.step_m = traverse.step_m;
  r.readings = traverse.pitch_rad.size();
  r.instrument = options.instrument;
  r.jitter = traverse.jitter;
  if (traverse.x_m.empty()) throw CsvError(traverse.source + ": empty traverse");
  r.vertical = straightness_from_stations(traverse.x_m, traverse.step_m, traverse.pitch_rad, options, "vertical");
  if (!traverse.yaw_rad.empty())
    r.horizontal = straightness_from_stations(traverse.x_m, traverse.step_m, traverse.yaw_rad, options, "horizontal");
  return r;
}

}  // namespace guideway::models::flatness
