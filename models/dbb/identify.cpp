// DBB identification (identify.hpp): Lai's model on every run (lai_fit.hpp), the ballbar diagnostics on the
// in-plane runs (diagnostics.hpp), the ISO 230-4 figures and what partial arcs and gaps hold.
#include "models/dbb/identify.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <Eigen/Core>
#include <Eigen/QR>

#include "models/dbb/arcs.hpp"
#include "models/dbb/diagnostics.hpp"
#include "models/dbb/fit_points.hpp"
#include "models/dbb/geometry.hpp"
#include "models/dbb/lai_fit.hpp"
#include "results/parameters.hpp"

namespace guideway::models::dbb {

CircleFit least_squares_circle(std::span<const double> angle_rad, std::span<const double> reading_um) {
  CircleFit out;
  const auto n = static_cast<Eigen::Index>(reading_um.size());
  if (n < 4 || angle_rad.size() != reading_um.size()) return out;
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd y(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    a.row(i) << 1.0, std::cos(angle_rad[static_cast<std::size_t>(i)]), std::sin(angle_rad[static_cast<std::size_t>(i)]);
    y[i] = reading_um[static_cast<std::size_t>(i)];
  }
  const Eigen::Vector3d c = a.colPivHouseholderQr().solve(y);
  const Eigen::VectorXd res = y - a * c;
  out.mean_um = c[0];
  out.cos_um = c[1];
  out.sin_um = c[2];
  out.deviation_um.assign(res.data(), res.data() + n);
  return out;
}

double range_about_circle(std::span<const double> angle_rad, std::span<const double> reading_um) {
  const CircleFit c = least_squares_circle(angle_rad, reading_um);
  if (c.deviation_um.empty()) return 0.0;
  const auto [lo, hi] = std::minmax_element(c.deviation_um.begin(), c.deviation_um.end());
  return *hi - *lo;
}

namespace {

using fitting::est;
using fitting::nan;

// ISO 230-4 circular deviation per run (the largest is G) and the hysteresis of the first ccw/cw pair
// of one set-up; each run's residual RMS from the diagnostics where they model it, else from Lai's fit.
void summarize_runs(const std::vector<formats::DbbRun>& runs, const std::vector<double>& residual_rms,
                    const std::vector<double>& lai_residual_rms, Identification& out) {
  out.standards = standard_figures(runs);
  double g_max = 0;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const formats::DbbRun& r = runs[k];
    RunSummary s;
    s.source = r.source;
    s.radius_mm = r.radius_m * 1e3;
    s.height_mm = r.height_m * 1e3;
    s.direction = r.direction == formats::DbbDirection::ccw ? "ccw" : "cw";
    s.feed_mm_per_min = r.feed_m_per_s * 60e3;
    s.n = r.angle_rad.size();
    s.circular_deviation_um = out.standards.runs[k].iso_circular_deviation_um;
    s.data_arc_deg = out.standards.runs[k].conditions.data_arc_deg;
    s.gaps = out.standards.runs[k].conditions.gaps;
    s.residual_rms_um = std::isfinite(residual_rms[k]) ? residual_rms[k] : lai_residual_rms[k];
    g_max = std::max(g_max, s.circular_deviation_um);
    out.runs.push_back(s);
  }
  out.diagnostics.push_back(est(results::name(results::circular_deviation), g_max, nan, false));
  if (!out.standards.pairs.empty())  // the first CCW/CW pair of one set-up
    out.diagnostics.push_back(est(results::name(results::circular_hysteresis),
                                  out.standards.pairs.front().iso_circular_hysteresis_um, nan, false));
}

}  // namespace

Identification identify(const std::vector<formats::DbbRun>& runs, const IdentifyOptions& options) {
  if (runs.empty()) throw formats::DbbRunFormatError("identify: no runs given");
  for (const auto& r : runs) formats::validate_dbb_run(r);
  const std::string plane = runs.front().plane;
  for (const auto& r : runs)
    if (r.plane != plane)
      throw formats::DbbRunFormatError(r.source + ": plane " + r.plane + " differs from " + runs.front().source + " (" +
                                       plane + "); runs identified together must share the plane");

  Identification out;
  out.plane = plane;
  std::vector<fitting::Point> pts = fitting::points_of(runs);
  std::size_t beside = 0;
  for (const BesideTerm& t : options.beside) {
    for (const auto& c : t.columns_um)
      if (c.size() != pts.size())
        throw std::invalid_argument("identify: the column of " + t.effect + " fitted beside has " +
                                    std::to_string(c.size()) + " values for " + std::to_string(pts.size()) +
                                    " samples");
    beside += t.columns_um.size();
  }
  fitting::FitWork work;
  // Widest fit: the Lai model with per-run centres or the diagnostics with every optional term
  // (spikes 2, decays 2, cyclic 4), and the terms fitted beside.
  work.j.resize(static_cast<Eigen::Index>(pts.size()),
                static_cast<Eigen::Index>(
                    2 * runs.size() +
                    std::max<std::size_t>(fitting::lai_column_count() - 2, fitting::diagnostics_max_columns) + beside));
  const fitting::LaiFit lai = fitting::fit_lai(runs, pts, drive_tracks(pts, drive_delays_s(runs)), work, options, out);
  const std::vector<double> residual_rms = fitting::diagnose_in_plane_runs(runs, plane, work, lai, options, out);
  if (out.ranking.empty()) {
    out.ranking = lai.ranking;
    out.ranking_model = "lai3";
  }
  summarize_runs(runs, residual_rms, lai.residual_rms, out);
  // A partial arc or a gap: what it holds and costs, and why each refused term is refused.
  const std::vector<std::string> arcs = arc_notes(runs, plane);
  out.notes.insert(out.notes.end(), arcs.begin(), arcs.end());
  if (!arcs.empty())
    for (FitSummary* f : {&out.fit, &out.diagnostics_fit})
      for (const auto& name : f->unidentifiable) f->why.push_back(name + ": " + why_unidentifiable(name, runs, plane));
  if (options.bar_length_u_um > 0) {
    std::ostringstream o;
    o << "every u includes the bar's calibrated length (u = " << options.bar_length_u_um
      << " um), the same offset in every reading: the absolute scales carry it (about u/L each), the scale "
         "mismatch and the shapes almost none";
    out.notes.push_back(o.str());
  }
  return out;
}

}  // namespace guideway::models::dbb
