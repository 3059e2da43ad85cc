// The circular test's ISO 230-4 and ASME B5.54 figures (standard_figures.hpp), each with the conditions that make it
// comparable.
#include "models/dbb/standard_figures.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "models/dbb/identify.hpp"

namespace guideway::models::dbb {

namespace {

constexpr double pi = std::numbers::pi;
constexpr double nan = std::numeric_limits<double>::quiet_NaN();

std::vector<double> reading_um(const formats::DbbRun& r) {
  std::vector<double> y(r.dL_m.size());
  for (std::size_t i = 0; i < y.size(); ++i) y[i] = r.dL_m[i] * 1e6;
  return y;
}

// Both runs' readings about their common least-squares circle (a's samples first).
CircleFit common_circle(const formats::DbbRun& a, const formats::DbbRun& b) {
  std::vector<double> angle(a.angle_rad), y = reading_um(a);
  angle.insert(angle.end(), b.angle_rad.begin(), b.angle_rad.end());
  const std::vector<double> yb = reading_um(b);
  y.insert(y.end(), yb.begin(), yb.end());
  return least_squares_circle(angle, y);
}

// A run's deviations `res` (one per sample) on a 0.5 deg grid of the wrapped angle (linear interpolation),
// NaN where the run has no samples (outside a partial arc, in a gap).
std::vector<double> on_grid(const formats::DbbRun& r, const double* res) {
  std::vector<std::pair<double, double>> v;
  for (std::size_t i = 0; i < r.angle_rad.size(); ++i) {
    double z = std::fmod(r.angle_rad[i], 2 * pi);
    if (z < 0) z += 2 * pi;
    v.emplace_back(z, res[i]);
  }
  std::sort(v.begin(), v.end());
  std::vector<double> g(720, nan);
  const std::vector<formats::DbbGap> gaps = formats::dbb_run_gaps(r);
  const bool whole = gaps.empty() && formats::dbb_run_full_circle(r);
  // The longest step between samples that is not a gap: a grid angle further from the samples is not held.
  double reach = 0.5 * pi / 180;
  for (std::size_t i = 1; i < v.size(); ++i) {
    const double step = v[i].first - v[i - 1].first;
    const bool in_gap =
        std::any_of(gaps.begin(), gaps.end(), [&](const formats::DbbGap& q) { return step >= 0.99 * q.angle_rad(); });
    if (!in_gap && step < pi / 2) reach = std::max(reach, step);
  }
  for (std::size_t k = 0; k < g.size(); ++k) {
    const double z = static_cast<double>(k) * pi / 360.0;
    auto it = std::lower_bound(v.begin(), v.end(), std::make_pair(z, -1e300));
    if (whole && (it == v.end() || it == v.begin())) {
      g[k] = (it == v.end() ? v.back() : v.front()).second;
      continue;
    }
    // Neighbours across 0 deg, where a partial arc may hold them.
    const auto& hi = it == v.end() ? v.front() : *it;
    const auto& lo = it == v.begin() ? v.back() : *(it - 1);
    const double span = std::fmod(hi.first - lo.first + 2 * pi, 2 * pi);
    if (!whole && span > reach * (1 + 1e-9) + 1e-12) continue;
    const double dz = std::fmod(z - lo.first + 2 * pi, 2 * pi);
    const double f = span > 0 ? dz / span : 0.0;
    g[k] = lo.second + f * (hi.second - lo.second);
  }
  return g;
}

// The two runs' deviations from their common least-squares circle on that grid.
std::pair<std::vector<double>, std::vector<double>> pair_grids(const formats::DbbRun& a, const formats::DbbRun& b) {
  const CircleFit c = common_circle(a, b);
  if (c.deviation_um.empty()) return {std::vector<double>(720, nan), std::vector<double>(720, nan)};
  return {on_grid(a, c.deviation_um.data()), on_grid(b, c.deviation_um.data() + a.angle_rad.size())};
}

std::optional<double> metadata_number(const formats::DbbRun& r, const std::string& key) {
  const auto it = r.metadata.find(key);
  if (it == r.metadata.end()) return std::nullopt;
  try {
    std::size_t used = 0;
    const double v = std::stod(it->second, &used);
    if (std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  return std::nullopt;  // not a number: not recorded usefully (the run format keeps it verbatim)
}

TestConditions conditions_of(const formats::DbbRun& r) {
  TestConditions c;
  c.radius_mm = r.radius_m * 1e3;
  c.height_mm = r.height_m * 1e3;
  c.feed_mm_per_min = r.feed_m_per_s * 60e3;
  c.direction = r.direction == formats::DbbDirection::ccw ? "ccw" : "cw";
  c.partial_arc = !formats::dbb_run_full_circle(r);
  c.data_arc_deg = !c.partial_arc       ? 360.0
                   : r.data_arc_rad > 0 ? r.data_arc_rad * 180 / pi
                                        : formats::dbb_run_arc_rad(r) * 180 / pi;
  c.samples = r.angle_rad.size();
  std::vector<double> step;
  for (std::size_t i = 1; i < r.angle_rad.size(); ++i) step.push_back(std::abs(r.angle_rad[i] - r.angle_rad[i - 1]));
  if (!step.empty()) {
    std::nth_element(step.begin(), step.begin() + static_cast<std::ptrdiff_t>(step.size() / 2), step.end());
    c.spacing_deg = step[step.size() / 2] * 180 / pi;
  }
  c.gaps = formats::dbb_run_gaps(r).size();
  const auto both = metadata_number(r, "overshoot_deg");
  c.feed_in_deg = metadata_number(r, "feed_in_deg");
  c.feed_out_deg = metadata_number(r, "feed_out_deg");
  if (!c.feed_in_deg) c.feed_in_deg = both;
  if (!c.feed_out_deg) c.feed_out_deg = both;
  c.temperature_c = metadata_number(r, "temperature_c");
  return c;
}

RunFigures run_figures(const formats::DbbRun& r) {
  RunFigures f;
  f.source = r.source;
  f.conditions = conditions_of(r);
  const CircleFit c = least_squares_circle(r.angle_rad, reading_um(r));
  if (c.deviation_um.empty()) return f;
  const auto [lo, hi] = std::minmax_element(c.deviation_um.begin(), c.deviation_um.end());
  f.iso_circular_deviation_um = *hi - *lo;
  // The reading is the bar's length less its nominal one: about the fitted centre it is the radial
  // deviation from the nominal circle (the fitted mean is the radius' own error, which F keeps).
  f.iso_radial_deviation_max_um = c.mean_um + *hi;
  f.iso_radial_deviation_min_um = c.mean_um + *lo;
  f.asme_circularity_um = f.iso_circular_deviation_um;
  return f;
}

bool same_setup(const formats::DbbRun& a, const formats::DbbRun& b) {
  return a.direction != b.direction && std::abs(a.radius_m - b.radius_m) < 1e-6 &&
         std::abs(a.height_m - b.height_m) < 1e-6 && a.plane == b.plane;
}

}  // namespace

double circular_hysteresis_um(const formats::DbbRun& a, const formats::DbbRun& b) {
  const auto [g1, g2] = pair_grids(a, b);
  double h = nan;
  for (std::size_t k = 0; k < g1.size(); ++k)
    if (std::isfinite(g1[k]) && std::isfinite(g2[k]))
      h = std::isfinite(h) ? std::max(h, std::abs(g1[k] - g2[k])) : std::abs(g1[k] - g2[k]);
  return h;
}

double common_arc_deg(const formats::DbbRun& a, const formats::DbbRun& b) {
  const auto [g1, g2] = pair_grids(a, b);
  std::size_t both = 0;
  for (std::size_t k = 0; k < g1.size(); ++k) both += std::isfinite(g1[k]) && std::isfinite(g2[k]) ? 1 : 0;
  return 0.5 * static_cast<double>(both);
}

StandardFigures standard_figures(const std::vector<formats::DbbRun>& runs) {
  StandardFigures out;
  for (const auto& r : runs) out.runs.push_back(run_figures(r));
  std::vector<bool> paired(runs.size(), false);
  for (std::size_t i = 0; i < runs.size(); ++i)
    for (std::size_t k = i + 1; k < runs.size() && !paired[i]; ++k) {
      if (paired[k] || !same_setup(runs[i], runs[k])) continue;
      const double h = circular_hysteresis_um(runs[i], runs[k]);
      if (!std::isfinite(h)) continue;  // their arcs do not overlap
      PairFigures p;
      const bool i_ccw = runs[i].direction == formats::DbbDirection::ccw;
      p.ccw = i_ccw ? i : k;
      p.cw = i_ccw ? k : i;
      p.common_arc_deg = common_arc_deg(runs[i], runs[k]);
      p.iso_circular_hysteresis_um = h;
      p.asme_hysteresis_um = h;
      const CircleFit c = common_circle(runs[i], runs[k]);
      const auto [lo, hi] = std::minmax_element(c.deviation_um.begin(), c.deviation_um.end());
      p.iso_bidirectional_deviation_um = *hi - *lo;
      p.asme_bidirectional_circularity_um = p.iso_bidirectional_deviation_um;
      out.pairs.push_back(p);
      paired[i] = paired[k] = true;
    }
  return out;
}

}  // namespace guideway::models::dbb
