// What identify's fits are built from and share (fit_points.hpp).
#include "models/dbb/fit_points.hpp"

#include <algorithm>
#include <cmath>
#include <span>

#include "models/common/amplitude_phase.hpp"
#include "models/dbb/arcs.hpp"
#include "results/parameters.hpp"

namespace guideway::models::dbb::fitting {

namespace {

// The axes' reversal terms are observable only when some run passes one of the axis' reversals.
void mask_unseen_reversals(const std::vector<formats::DbbRun>& runs, std::vector<Point>& pts) {
  const double a = reversals_in_arcs(runs, 0).seen_deg.empty() ? 0.0 : 1.0;
  const double b = reversals_in_arcs(runs, 1).seen_deg.empty() ? 0.0 : 1.0;
  for (Point& p : pts) {
    p.rev_a = a;
    p.rev_b = b;
  }
}

}  // namespace

void set_step_backlash(Point& p) {
  p.bl_a = -0.5 * p.sgn_a;
  p.bl_b = -0.5 * p.sgn_b;
}

std::vector<Point> points_of(const std::vector<formats::DbbRun>& runs, const std::vector<std::size_t>& first_sample) {
  std::vector<Point> pts;
  // Each run's samples weigh as its sampling density along the arc it covers: runs sampled at different
  // rates count alike per degree, and a run that lost samples to a gap or covers a partial arc counts for
  // the arc it holds (its uncertainties grow), not as a whole circle. On full circles: every run alike.
  std::size_t total = 0;
  double covered_total = 0;
  bool all_whole = true;
  std::vector<double> covered(runs.size());
  for (std::size_t k = 0; k < runs.size(); ++k) {
    total += runs[k].angle_rad.size();
    const bool whole = formats::dbb_run_full_circle(runs[k]) && formats::dbb_run_gaps(runs[k]).empty();
    covered[k] = whole ? 2 * pi : formats::dbb_run_covered_rad(runs[k]);
    all_whole = all_whole && whole;
    covered_total += covered[k];
  }
  pts.reserve(total);
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const formats::DbbRun& run = runs[k];
    // 1 on full circles: the weights exactly as before partial arcs.
    const double arc_share = all_whole ? 1.0 : covered[k] * static_cast<double>(runs.size()) / covered_total;
    const double w = arc_share * static_cast<double>(total) /
                     (static_cast<double>(runs.size()) * static_cast<double>(run.angle_rad.size()));
    const std::size_t first = first_sample.empty() ? pts.size() : first_sample[k];
    for (std::size_t i = 0; i < run.angle_rad.size(); ++i) {
      Point& p = pts.emplace_back();  // filled in place (10^4 points of 200 bytes)
      fill_sample_geometry(run, k, i, p);
      set_step_backlash(p);
      p.w = w;
      p.sample = first + i;
    }
  }
  mask_unseen_reversals(runs, pts);
  return pts;
}

BesideColumns beside_columns(const IdentifyOptions& options, bool diagnostics) {
  BesideColumns out;
  for (const BesideTerm& t : options.beside) {
    if (diagnostics && !t.in_diagnostics) continue;
    for (std::size_t c = 0; c < t.columns_um.size(); ++c) {
      out.columns.push_back(&t.columns_um[c]);
      out.names.push_back(c < t.names.size() ? t.names[c] : t.effect + "_" + std::to_string(c + 1));
    }
  }
  return out;
}

void set_deadband(std::vector<Point>& pts, const DriveTrack& track, double b_a, double b_b) {
  for (std::size_t i = 0; i < pts.size(); ++i) {
    Point& p = pts[i];
    const auto m = lost_motion(track, p, i, b_a, b_b);
    p.bl_a = b_a > 0 ? m[0] : -0.5 * p.sgn_a;
    p.bl_b = b_b > 0 ? m[1] : -0.5 * p.sgn_b;
  }
}

FitSummary summary_of(const LsqResult& res) {
  FitSummary f;
  f.rms_um = res.rms;
  f.n = res.n;
  f.condition_number = res.condition_number;
  f.unidentifiable = res.unidentifiable;
  f.combinations = res.combinations;
  f.message = res.message;
  return f;
}

LsqResult solved(LsqResult res) {
  if (!res.ok) throw FitError("identify: " + res.message);
  return res;
}

Eigen::Index strided_rows(Eigen::Index n, Eigen::Index cols, Eigen::Index stride) {
  return (stride <= 1 || n / stride <= 4 * cols) ? n : (n + stride - 1) / stride;
}

LsqResult solve_strided(const Eigen::Ref<const Eigen::MatrixXd>& j, const Eigen::VectorXd& y, const Eigen::VectorXd& w,
                        const std::vector<std::string>& names, Eigen::Index stride) {
  const Eigen::Index m = strided_rows(j.rows(), j.cols(), stride);
  if (m == j.rows()) return solve_lsq(j, y, w, names);
  Eigen::MatrixXd js(m, j.cols());
  Eigen::VectorXd ys(m), ws(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    js.row(i) = j.row(i * stride);
    ys[i] = y[i * stride];
    ws[i] = w[i * stride];
  }
  LsqResult r = solve_lsq(js, ys, ws, names);
  if (!r.ok) return r;
  r.residual = y - j * r.fitted;
  r.rms = std::sqrt(r.residual.squaredNorm() / static_cast<double>(j.rows()));
  return r;
}

// An error of the bar's calibrated length is the same offset in every dL, which a linear fit turns into that
// offset times its solution for dL = 1 um, s. Its standard uncertainty u_L adds |s_k| u_L to each parameter's u
// in quadrature and u_L^2 s s^T to the covariance, so what is computed from the covariance afterwards (the
// scale mismatch, a cyclic amplitude) carries its part too: none for the mismatch, whose two scales move
// together.
void add_bar_length_uncertainty(LsqResult& res, const Eigen::Ref<const Eigen::MatrixXd>& j, const Eigen::VectorXd& w,
                                const std::vector<std::string>& names, double u_length_um) {
  if (!(u_length_um > 0) || !res.ok) return;
  const LsqResult response = solve_lsq(j, Eigen::VectorXd::Ones(j.rows()), w, names);
  if (!response.ok) return;
  Eigen::VectorXd s = Eigen::VectorXd::Zero(res.x.size());
  for (std::size_t k = 0; k < res.identified.size(); ++k) {
    if (!res.identified[k] || !response.identified[k]) continue;
    const auto i = static_cast<Eigen::Index>(k);
    s[i] = response.x[i] * u_length_um;
    res.u[i] = std::hypot(res.u[i], s[i]);
  }
  res.covariance += s * s.transpose();
}

double circular_deviation(const Point* p, std::size_t n_points) {
  std::vector<double> zeta(n_points), y(n_points);
  for (std::size_t i = 0; i < n_points; ++i) {
    zeta[i] = p[i].zeta_rad;
    y[i] = p[i].dL_um;
  }
  return range_about_circle(zeta, y);
}

double part_of_deviation(const std::vector<Point>& pts, const std::vector<double>& curve, std::size_t runs) {
  double out = 0;
  for (std::size_t k = 0, i0 = 0; k < runs; ++k) {
    std::size_t i1 = i0;
    while (i1 < pts.size() && pts[i1].run == k) ++i1;
    std::vector<double> zeta;
    for (std::size_t i = i0; i < i1; ++i) zeta.push_back(pts[i].zeta_rad);
    if (i1 > i0 + 3) out = std::max(out, range_about_circle(zeta, std::span<const double>(curve).subspan(i0, i1 - i0)));
    i0 = i1;
  }
  return out;
}

void add_beside(const LsqResult& res, const std::vector<std::string>& names, std::size_t first, std::size_t end,
                std::vector<Estimate>& beside) {
  beside.clear();
  for (std::size_t c = first; c < end; ++c)
    if (res.identified[c])
      beside.push_back(est(names[c], res.x[static_cast<Eigen::Index>(c)], res.u[static_cast<Eigen::Index>(c)]));
  for (std::size_t i = first; i < end; ++i) {
    const auto line = results::line_of_part(names[i]);
    if (!line || names[i] != line->sine || !res.identified[i]) continue;
    const auto cos_at = std::find(names.begin() + static_cast<std::ptrdiff_t>(first),
                                  names.begin() + static_cast<std::ptrdiff_t>(end), line->cosine);
    const auto j = static_cast<std::size_t>(cos_at - names.begin());
    if (j == end || !res.identified[j]) continue;
    const auto si = static_cast<Eigen::Index>(i), ci = static_cast<Eigen::Index>(j);
    const AmplitudePhase a =
        amplitude_phase(res.x[si], res.x[ci], res.covariance(si, si), res.covariance(ci, ci), res.covariance(si, ci));
    beside.push_back(est(line->amplitude, a.amplitude, a.u_amplitude));
    beside.push_back(est(line->phase, a.phase_rad * 180 / pi, a.u_phase_rad * 180 / pi));
  }
}

}  // namespace guideway::models::dbb::fitting
