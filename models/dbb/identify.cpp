#include "models/dbb/identify.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <sstream>

#include <Eigen/Core>
#include <Eigen/QR>

#include "models/common/amplitude_phase.hpp"
#include "models/common/least_squares.hpp"
#include "models/dbb/arcs.hpp"
#include "models/dbb/fast_sincos.hpp"
#include "models/dbb/geometry.hpp"
#include "results/parameters.hpp"

namespace guideway::models::dbb {

namespace {

constexpr double pi = std::numbers::pi;
constexpr double nan = std::numeric_limits<double>::quiet_NaN();
constexpr double um = 1e-6;

// Per-sample geometry and what the fits add to it.
struct Point : SampleGeometry {
  double bl_a = 0, bl_b = 0;      // lost motion per unit backlash: -sgn/2 for an ideal step, or the
                                  // deadband response at the current backlash estimate
  double cyc_sa = 0, cyc_ca = 0;  // sin and cos of the cyclic phase 2 pi a_m / period_a (and b),
  double cyc_sb = 0, cyc_cb = 0;  // once the periods are chosen (set_cyclic_phases)
  double w = 1;
  std::size_t sample = 0;  // among all the runs identified: the row of IdentifyOptions::beside's columns
  // 0 when no run passes a reversal of the axis (a partial arc: arcs.hpp): its reversal terms' columns
  // are then zero, so the fits refuse them by name instead of reading them from the arc's ends.
  double rev_a = 1, rev_b = 1;
};

// The axes' reversal terms are observable only when some run passes one of the axis' reversals.
void mask_unseen_reversals(const std::vector<formats::DbbRun>& runs, std::vector<Point>& pts) {
  const double a = reversals_in_arcs(runs, 0).seen_deg.empty() ? 0.0 : 1.0;
  const double b = reversals_in_arcs(runs, 1).seen_deg.empty() ? 0.0 : 1.0;
  for (Point& p : pts) {
    p.rev_a = a;
    p.rev_b = b;
  }
}

// The ideal step: the axis trails the command by half the backlash, on the side it comes from.
void set_step_backlash(Point& p) {
  p.bl_a = -0.5 * p.sgn_a;
  p.bl_b = -0.5 * p.sgn_b;
}

// The points of `runs`; run k's first sample is sample first_sample[k] of all the runs identified (none
// given: the runs are all of them).
std::vector<Point> points_of(const std::vector<formats::DbbRun>& runs,
                             const std::vector<std::size_t>& first_sample = {}) {
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

// The columns of the terms fitted beside a model's own (all of them, or those the diagnostics do not hold),
// with their names.
struct BesideColumns {
  std::vector<const std::vector<double>*> columns;
  std::vector<std::string> names;
  [[nodiscard]] std::size_t size() const { return columns.size(); }
  [[nodiscard]] double at(std::size_t c, const Point& p) const { return (*columns[c])[p.sample]; }
};

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

// The points' backlash column: the deadband of width b_a / b_b (m) on the drives' track (the one deadband
// EXPLAIN's backlash effect uses: geometry.hpp), the ideal step for a width <= 0.
void set_deadband(std::vector<Point>& pts, const DriveTrack& track, double b_a, double b_b) {
  for (std::size_t i = 0; i < pts.size(); ++i) {
    Point& p = pts[i];
    const auto m = lost_motion(track, i, b_a, b_b);
    p.bl_a = b_a > 0 ? m[0] : -0.5 * p.sgn_a;
    p.bl_b = b_b > 0 ? m[1] : -0.5 * p.sgn_b;
  }
}

// The deadband a fit reads: its widths (m) and the drives' delay behind the commanded angles (s).
struct Deadband {
  double b_a = 0, b_b = 0;
  std::size_t track = 0;  // index into the tracks (their delay_s)
  [[nodiscard]] bool shaped() const { return b_a > 0 || b_b > 0; }
};

// The deadband of widths `widths` that fits best: at every drive delay of `tracks` the points get its shape
// and `rms(pts)` (a fit's residual RMS) is evaluated; the lowest wins, and the points keep its shape. With
// one track (the angles are the encoders') only the widths are set.
template <class RmsOf>
Deadband choose_deadband_delay(std::vector<Point>& pts, const std::vector<DriveTrack>& tracks, Deadband widths,
                               const RmsOf& rms) {
  widths.b_a = std::max(widths.b_a, 0.0);
  widths.b_b = std::max(widths.b_b, 0.0);
  if (widths.shaped() && tracks.size() > 1) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < tracks.size(); ++k) {
      set_deadband(pts, tracks[k], widths.b_a, widths.b_b);
      const double e = rms(pts);
      if (e < best) {
        best = e;
        widths.track = k;
      }
    }
  }
  set_deadband(pts, tracks[widths.track], widths.b_a, widths.b_b);
  return widths;
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

// ---- Lai third-order model -------------------------------------------------------------------

struct LaiColumn {
  const results::Parameter* parameter;
  double si_per_reported;  // SI value of one reported unit
};

// Order matters: lai3_characteristics returns the basis in this order.
constexpr LaiColumn lai_columns[] = {
    {&results::lai_e_x, 1e-6},        {&results::lai_e_y, 1e-6},
    {&results::lai_S_x, 1.0},         {&results::lai_S_y, 1.0},
    {&results::lai_a1, 1.0},          {&results::lai_a2, 1e3},
    {&results::lai_a3, 1e6},          {&results::lai_b2, 1e3},
    {&results::lai_b3, 1e6},          {&results::lai_c0_plus_d1, 1.0},
    {&results::lai_c1, 1e3},          {&results::lai_c2, 1e6},
    {&results::lai_d2, 1e3},          {&results::lai_d3, 1e6},
    {&results::lai_e1, 1.0},          {&results::lai_e2, 1e3},
    {&results::lai_e3, 1e6},          {&results::lai_backlash_x, 1e-6},
    {&results::lai_backlash_y, 1e-6}, {&results::lai_servo_mismatch, 1e-3},
};
constexpr std::size_t lai_count = std::size(lai_columns);

void lai_basis(const Point& p, double* out) {
  const double c = p.c, s = p.s, r = p.radius_m, lam = p.lambda, hl = p.h_over_l0;
  out[0] = -lam * c;
  out[1] = -lam * s;
  out[2] = lam * r * c * c;
  out[3] = lam * r * s * s;
  out[4] = lam * r * s * c;
  out[5] = lam * r * r * c * c * s;
  out[6] = lam * r * r * r * c * c * c * s;
  out[7] = lam * r * r * s * s * c;
  out[8] = lam * r * r * r * s * s * s * c;
  out[9] = hl * r * c;
  out[10] = hl * r * r * c * s;
  out[11] = hl * r * r * r * c * s * s;
  out[12] = hl * r * r * c * c;
  out[13] = hl * r * r * r * c * c * c;
  out[14] = hl * r * s;
  out[15] = hl * r * r * s * s;
  out[16] = hl * r * r * r * s * s * s;
  out[17] = lam * p.bl_a * c * p.rev_a;
  out[18] = lam * p.bl_b * s * p.rev_b;
  out[19] = lam * p.dir * p.feed_m_per_s * s * c;
}

// ---- Ballbar diagnostics -------------------------------------------------------------------------

struct DiagLayout {
  std::size_t runs = 0;
  bool spikes = false;
  // Gauss-Newton columns for the decay times, when a spike is clearly present (amp_* = its height
  // from the search, um): the decay and the height are then fitted together with their covariance.
  bool decay_a = false, decay_b = false;
  double amp_a = 0, amp_b = 0;
  bool cyclic_a = false, cyclic_b = false;
  double tau_a = assumed_spike_decay_s, tau_b = assumed_spike_decay_s, delay_a = 0, delay_b = 0, period_a = 0,
         period_b = 0;
  const BesideColumns* beside = nullptr;  // fitted beside, after every diagnostic (may be null)
  [[nodiscard]] std::size_t beside_count() const { return beside ? beside->size() : 0; }
  [[nodiscard]] std::size_t global0() const { return 2 * runs; }
  // global parameters after the per-run centre offsets
  enum G {
    scale_a,
    scale_b,
    squareness,
    backlash_a,
    backlash_b,
    play_a,
    play_b,
    servo,
    bow_a,
    bow_b,
    cubic,  // the difference of the axes' cubic straightness, all a circle sees of them besides a squareness
    n_base
  };
  [[nodiscard]] std::size_t count() const {
    return global0() + n_base + (spikes ? 2 : 0) + (decay_a ? 1 : 0) + (decay_b ? 1 : 0) + (cyclic_a ? 2 : 0) +
           (cyclic_b ? 2 : 0) + beside_count();
  }
  [[nodiscard]] std::size_t spike0() const { return global0() + n_base; }
  [[nodiscard]] std::size_t decay_a0() const { return spike0() + (spikes ? 2 : 0); }
  [[nodiscard]] std::size_t decay_b0() const { return decay_a0() + (decay_a ? 1 : 0); }
  [[nodiscard]] std::size_t cyc_a0() const { return decay_b0() + (decay_b ? 1 : 0); }
  [[nodiscard]] std::size_t cyc_b0() const { return cyc_a0() + (cyclic_a ? 2 : 0); }
  [[nodiscard]] std::size_t beside0() const { return cyc_b0() + (cyclic_b ? 2 : 0); }
};

// Column values in um per reported unit (um, ppm, urad, ms).
void diag_row(const DiagLayout& L, const Point& p, Eigen::RowVectorXd& row) {
  row.setZero();
  const double c = p.c, s = p.s, lam = p.lambda, r = p.radius_m;
  row[static_cast<Eigen::Index>(2 * p.run)] = lam * c;
  row[static_cast<Eigen::Index>(2 * p.run + 1)] = lam * s;
  const auto g = static_cast<Eigen::Index>(L.global0());
  row[g + DiagLayout::scale_a] = lam * r * c * c;  // 1 ppm = 1e-6 * r m = r um
  row[g + DiagLayout::scale_b] = lam * r * s * s;
  row[g + DiagLayout::squareness] = lam * r * s * c;
  row[g + DiagLayout::backlash_a] = lam * p.bl_a * c * p.rev_a;
  row[g + DiagLayout::backlash_b] = lam * p.bl_b * s * p.rev_b;
  row[g + DiagLayout::play_a] = lam * 0.5 * p.sgn_a * s * p.rev_a;
  row[g + DiagLayout::play_b] = lam * 0.5 * p.sgn_b * c * p.rev_b;
  row[g + DiagLayout::servo] = lam * p.dir * p.feed_m_per_s * s * c * 1e3;  // 1 ms = 1e-3 s; v m/s -> um: *1e6*1e-3
  row[g + DiagLayout::bow_a] = lam * s * c * c;
  row[g + DiagLayout::bow_b] = lam * c * s * s;
  // (a3 c^3 s + b3 s^3 c) r^3 = (a3 + b3) r^3 sin 2 zeta / 4 + (a3 - b3) r^3 s c (c^2 - s^2) / 2: the first part
  // is a squareness, the second (a 4th harmonic) this term. On an evenly sampled full circle it is orthogonal
  // to every other column, but not once a gap takes samples away: left out, its ~1 um then went into the
  // backlash, play, servo mismatch and squareness (docs/conventions.md, "Planes and partial arcs").
  row[g + DiagLayout::cubic] = lam * 0.5 * s * c * (c * c - s * s);
  if (L.spikes) {
    const auto k = static_cast<Eigen::Index>(L.spike0());
    row[k] = lam * c * (-p.sgn_a) * reversal_spike_decay(p.since_a_s - L.delay_a, L.tau_a) * p.rev_a;
    row[k + 1] = lam * s * (-p.sgn_b) * reversal_spike_decay(p.since_b_s - L.delay_b, L.tau_b) * p.rev_b;
  }
  // d/dtau of A exp(-t/tau) = A t / tau^2 exp(-t/tau), per ms of tau.
  if (L.decay_a) {
    const double t = p.since_a_s - L.delay_a;
    row[static_cast<Eigen::Index>(L.decay_a0())] =
        lam * c * (-p.sgn_a) * L.amp_a * t / (L.tau_a * L.tau_a) * reversal_spike_decay(t, L.tau_a) * 1e-3;
  }
  if (L.decay_b) {
    const double t = p.since_b_s - L.delay_b;
    row[static_cast<Eigen::Index>(L.decay_b0())] =
        lam * s * (-p.sgn_b) * L.amp_b * t / (L.tau_b * L.tau_b) * reversal_spike_decay(t, L.tau_b) * 1e-3;
  }
  if (L.cyclic_a) {
    const auto k = static_cast<Eigen::Index>(L.cyc_a0());
    row[k] = lam * c * p.cyc_sa;
    row[k + 1] = lam * c * p.cyc_ca;
  }
  if (L.cyclic_b) {
    const auto k = static_cast<Eigen::Index>(L.cyc_b0());
    row[k] = lam * s * p.cyc_sb;
    row[k + 1] = lam * s * p.cyc_cb;
  }
  for (std::size_t k = 0; k < L.beside_count(); ++k)
    row[static_cast<Eigen::Index>(L.beside0() + k)] = L.beside->at(k, p);
}

// The cyclic-error phases of the chosen lead-screw periods, computed once for every later fit.
void set_cyclic_phases(const DiagLayout& L, std::vector<Point>& pts) {
  for (auto& p : pts) {
    if (L.cyclic_a) {
      const double th = 2 * pi * p.a_m / L.period_a;
      p.cyc_sa = std::sin(th);
      p.cyc_ca = std::cos(th);
    }
    if (L.cyclic_b) {
      const double th = 2 * pi * p.b_m / L.period_b;
      p.cyc_sb = std::sin(th);
      p.cyc_cb = std::cos(th);
    }
  }
}

std::vector<std::string> diag_names(const DiagLayout& L, const std::string& plane) {
  const auto both = [&](const results::Parameter& p, std::vector<std::string>& n) {
    n.push_back(results::name(p, plane, 0));
    n.push_back(results::name(p, plane, 1));
  };
  std::vector<std::string> n;
  for (std::size_t k = 0; k < L.runs; ++k) {
    // One run: plain names; several: run1.center_offset_*, run2.center_offset_*, ...
    for (int axis = 0; axis < 2; ++axis) {
      const std::string name = results::name(results::center_offset, plane, axis);
      n.push_back(L.runs > 1 ? results::run_prefixed(static_cast<int>(k + 1), name) : name);
    }
  }
  both(results::scale, n);
  n.push_back(results::name(results::squareness));
  both(results::backlash, n);
  both(results::lateral_play, n);
  n.push_back(results::name(results::servo_mismatch));
  both(results::straightness_bow, n);
  n.push_back(results::name(results::straightness_cubic_difference, plane));
  if (L.spikes) both(results::reversal_spike, n);
  if (L.decay_a) n.push_back(results::name(results::reversal_spike_decay, plane, 0));
  if (L.decay_b) n.push_back(results::name(results::reversal_spike_decay, plane, 1));
  if (L.cyclic_a) {
    n.push_back(results::name(results::cyclic_sin, plane, 0));
    n.push_back(results::name(results::cyclic_cos, plane, 0));
  }
  if (L.cyclic_b) {
    n.push_back(results::name(results::cyclic_sin, plane, 1));
    n.push_back(results::name(results::cyclic_cos, plane, 1));
  }
  if (L.beside) n.insert(n.end(), L.beside->names.begin(), L.beside->names.end());
  return n;
}

// Rows a preliminary fit on every stride-th point uses: all n when that would leave too few for
// `cols` parameters.
Eigen::Index strided_rows(Eigen::Index n, Eigen::Index cols, Eigen::Index stride) {
  return (stride <= 1 || n / stride <= 4 * cols) ? n : (n + stride - 1) / stride;
}

// Least squares on every stride-th row only (a preliminary fit whose estimates steer a search or a
// basis shape); the residual is then evaluated on all rows.
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

// The bar's calibrated length is in every reading (the length encoder's offset): an error of it is the
// same offset in every dL, which a linear fit turns into that offset times its solution for dL = 1 um,
// s. Its standard uncertainty u_L adds |s_k| u_L to each parameter's u in quadrature and u_L^2 s s^T to
// the covariance, so what is computed from the covariance afterwards (the scale mismatch, a cyclic
// amplitude) carries its part too: none for the mismatch, whose two scales move together.
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

// The design matrix buffer of all fits of one identification (n rows, as many columns as the widest
// fit: one allocation, its pages touched once) and the data of the diagnostics fits.
struct DiagWork {
  Eigen::MatrixXd j;
  Eigen::VectorXd y, w;
};

LsqResult fit_diag(const DiagLayout& L, const std::vector<Point>& pts, const std::string& plane, DiagWork& work,
                   Eigen::Index stride = 1) {
  const auto n = static_cast<Eigen::Index>(pts.size());
  if (work.j.rows() != n || work.j.cols() < static_cast<Eigen::Index>(L.count()))
    work.j.resize(n, static_cast<Eigen::Index>(L.count()));
  auto j = work.j.leftCols(static_cast<Eigen::Index>(L.count()));
  if (work.y.size() != n) {
    work.y.resize(n);
    work.w.resize(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      work.y[i] = pts[static_cast<std::size_t>(i)].dL_um;
      work.w[i] = pts[static_cast<std::size_t>(i)].w;
    }
  }
  Eigen::RowVectorXd row(j.cols());
  for (Eigen::Index i = 0; i < n; ++i) {
    diag_row(L, pts[static_cast<std::size_t>(i)], row);
    j.row(i) = row;
  }
  return solve_strided(j, work.y, work.w, diag_names(L, plane), stride);
}

// Weighted sum of squares explained by fitting two extra columns to a residual.
// With stride > 1 only every stride-th point is used and the result scaled back.
template <typename Cols>
double explained(const std::vector<Point>& pts, const Eigen::VectorXd& res, const Cols& cols, std::size_t stride = 1) {
  double s11 = 0, s12 = 0, s22 = 0, b1 = 0, b2 = 0;
  for (std::size_t i = 0; i < pts.size(); i += stride) {
    double u1 = 0, u2 = 0;
    cols(pts[i], u1, u2);
    const double w = pts[i].w;
    s11 += w * u1 * u1;
    s12 += w * u1 * u2;
    s22 += w * u2 * u2;
    b1 += w * u1 * res[static_cast<Eigen::Index>(i)];
    b2 += w * u2 * res[static_cast<Eigen::Index>(i)];
  }
  const double det = s11 * s22 - s12 * s12;
  if (!(det > 1e-300)) return 0.0;
  const double x1 = (s22 * b1 - s12 * b2) / det;
  const double x2 = (s11 * b2 - s12 * b1) / det;
  return (x1 * b1 + x2 * b2) * static_cast<double>(stride);
}

// ISO 230-4 circular deviation of one run (its points start at `p`, n of them) about its
// least-squares circle.
double circular_deviation(const Point* p, std::size_t n_points) {
  std::vector<double> zeta(n_points), y(n_points);
  for (std::size_t i = 0; i < n_points; ++i) {
    zeta[i] = p[i].zeta_rad;
    y[i] = p[i].dL_um;
  }
  return range_about_circle(zeta, y);
}

// A term's part of the circular deviation: per run, the range of its curve (values per point, in run
// order) about the least-squares circle; the largest over the runs.
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

Estimate est(const std::string& name, double value, double u, bool fitted = true) { return {name, value, u, fitted}; }

}  // namespace

std::vector<std::string> lai3_parameter_names() {
  std::vector<std::string> n;
  for (const auto& c : lai_columns) n.emplace_back(c.parameter->name);
  return n;
}

std::vector<double> lai3_characteristics(double radius_m, double height_m, int direction, double feed_m_per_s,
                                         double zeta) {
  Point p{circle_geometry(radius_m, height_m, direction, feed_m_per_s, zeta)};
  set_step_backlash(p);
  std::vector<double> out(lai_count);
  lai_basis(p, out.data());
  return out;
}

double lai3_exact_dL(const Lai3Params& q, double radius_m, double height_m, int direction, double feed_m_per_s,
                     double zeta) {
  const double r = radius_m, h = height_m;
  const double c = std::cos(zeta), s = std::sin(zeta);
  const double a = r * c, b = r * s;  // commanded position about the circle centre
  const double sgn_a = velocity_sign_a(direction, s), sgn_b = velocity_sign_b(direction, c);
  const double omega = feed_m_per_s / r;
  // Servo lag difference: x lags by the whole mismatch relative to y (only the difference matters).
  const double lag = direction * omega * q.servo_mismatch_s;
  const double a_servo = r * std::cos(zeta - lag);
  double xa = q.s_x * a_servo - 0.5 * q.backlash_x * sgn_a + q.b2 * b * b + q.b3 * b * b * b;
  double xb = q.s_y * b - 0.5 * q.backlash_y * sgn_b + q.a1 * a + q.a2 * a * a + q.a3 * a * a * a;
  const double xn = q.d1 * a + q.d2 * a * a + q.d3 * a * a * a + q.e1 * b + q.e2 * b * b + q.e3 * b * b * b +
                    a * (q.c0 + q.c1 * b + q.c2 * b * b);
  // Moving ball relative to the fixed ball at (e_x, e_y, -h).
  xa -= q.e_x;
  xb -= q.e_y;
  const double len = std::sqrt(xa * xa + xb * xb + (xn + h) * (xn + h));
  return len - std::sqrt(r * r + h * h);
}

// Each diagnosed error's part of the circular deviation, as a ballbar's software ranks them ("what to
// fix first"): the range of its fitted term about the least-squares circle over a run (the largest over
// the runs), as G is the reading's, and that as a percentage of the largest G. The centre offset is the
// set-up's, not the machine's, and is not ranked. Terms partly cancel: the percentages need not add up
// to 100.
void rank_contributions(const DiagLayout& L, const LsqResult& res, const std::vector<Point>& pts,
                        const std::vector<formats::DbbRun>& runs, const std::vector<std::string>& names,
                        const std::string& plane, Identification& out) {
  const std::size_t g = L.global0();
  std::vector<std::vector<std::size_t>> terms{{g + DiagLayout::scale_a, g + DiagLayout::scale_b}};  // scale mismatch
  for (auto k : {DiagLayout::squareness, DiagLayout::backlash_a, DiagLayout::backlash_b, DiagLayout::play_a,
                 DiagLayout::play_b, DiagLayout::servo, DiagLayout::bow_a, DiagLayout::bow_b, DiagLayout::cubic})
    terms.push_back({g + k});
  if (L.spikes) {
    terms.push_back({L.spike0()});
    terms.push_back({L.spike0() + 1});
  }
  if (L.cyclic_a) terms.push_back({L.cyc_a0(), L.cyc_a0() + 1});
  if (L.cyclic_b) terms.push_back({L.cyc_b0(), L.cyc_b0() + 1});
  double g_max = 0;
  for (std::size_t k = 0, i = 0; k < runs.size(); i += runs[k].angle_rad.size(), ++k)
    g_max = std::max(g_max, circular_deviation(pts.data() + i, runs[k].angle_rad.size()));
  Eigen::RowVectorXd row(static_cast<Eigen::Index>(L.count()));
  for (const auto& cols : terms) {
    if (std::any_of(cols.begin(), cols.end(), [&](std::size_t c) { return !res.identified[c]; })) continue;
    std::vector<double> curve(pts.size(), 0.0);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      diag_row(L, pts[i], row);
      for (const std::size_t c : cols)
        curve[i] += row[static_cast<Eigen::Index>(c)] * res.x[static_cast<Eigen::Index>(c)];
    }
    const double part = part_of_deviation(pts, curve, runs.size());
    // Named as the diagnostic (the scales as their mismatch, the cyclic error's two columns after its axis).
    std::string name = names[cols.front()];
    if (cols.front() == g + DiagLayout::scale_a)
      name = results::name(results::scale_mismatch);
    else if (cols.size() == 2)
      name = results::name(results::cyclic_error, plane, L.cyclic_a && cols.front() == L.cyc_a0() ? 0 : 1);
    out.ranking.push_back({name, part, g_max > 0 ? 100 * part / g_max : nan});
  }
  std::sort(out.ranking.begin(), out.ranking.end(),
            [](const Contribution& a, const Contribution& b) { return a.contribution_um > b.contribution_um; });
}

// A reversal spike of one axis as the search finds it: decay time and delay after the commanded reversal
// (s), height (um) and whether it explains clearly more than noise.
struct SpikeShape {
  double tau = assumed_spike_decay_s, delay = 0, amp = 0;
  bool significant = false;
};

// The points shortly after an axis' reversal, where a spike lives: time since the reversal, the spike
// column's value at decay 0, the weight and the preliminary fit's residual.
struct SpikePoint {
  double since, u, w, r;
};

// The least-squares sums of a spike of decay `tau` started `delay` after the reversal against the residual:
// sum w u r and sum w u^2.
std::pair<double, double> spike_sums(const std::vector<SpikePoint>& near, double tau, double delay) {
  double sur = 0, suu = 0;
  for (const auto& q : near) {
    const double t = q.since - delay;
    if (t < 0 || t > 8 * tau) continue;
    const double u = q.u * std::exp(-t / tau);
    sur += q.w * u * q.r;
    suu += q.w * u * u;
  }
  return {sur, suu};
}

// What a spike explains of the residual (sur^2 / suu), 0 when it reaches no point.
double spike_score(const std::vector<SpikePoint>& near, double tau, double delay) {
  const auto [sur, suu] = spike_sums(near, tau, delay);
  return suu > 0 ? sur * sur / suu : 0.0;
}

// Per axis: the decay time (log grid 2..100 ms, then golden section; never below half the sample spacing
// `dt`, where a "spike" would be one sample's noise) and the delay of the spike after the commanded
// reversal (the axis' servo lag, 0..`delay_max`) that explain most of the residual. When that is not
// clearly more than noise, a spike at the reversal decaying in 20 ms, or two sample spacings when the
// samples are further apart than 10 ms: the height then reported is that of a stiction spike the sampling
// resolves, consistent with none.
SpikeShape search_spike(const std::vector<Point>& pts, const LsqResult& base, bool axis_a, double delay_step,
                        double delay_max, double dt) {
  const double tau_min = 0.5 * dt;
  constexpr double tau_max = 0.1;
  std::vector<SpikePoint> near;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Point& p = pts[i];
    const double since = axis_a ? p.since_a_s : p.since_b_s;
    if (since > 8 * tau_max + delay_max) continue;
    const double u = p.lambda * (axis_a ? p.c * -p.sgn_a * p.rev_a : p.s * -p.sgn_b * p.rev_b);
    if (u == 0.0) continue;
    near.push_back({since, u, p.w, base.residual[static_cast<Eigen::Index>(i)]});
  }
  double best = 0, best_tau = assumed_spike_decay_s, best_delay = 0;
  constexpr int grid = 12;
  for (double d = 0; d <= delay_max + 1e-12; d += delay_step) {
    for (int q = 0; q < grid; ++q) {
      const double tau = 0.002 * std::pow(50.0, static_cast<double>(q) / (grid - 1));
      if (tau < tau_min) continue;
      const double e = spike_score(near, tau, d);
      if (e > best * (1 + 1e-9)) {  // ties (a delay shorter than the sample spacing): keep the shortest
        best = e;
        best_tau = tau;
        best_delay = d;
      }
    }
  }
  // Refine the delay (when the sampling resolves it) and the decay (golden section in log tau).
  for (double d = std::max(0.0, best_delay - delay_step); delay_step < 0.004 && d <= best_delay + delay_step + 1e-12;
       d += 0.25 * delay_step) {
    const double e = spike_score(near, best_tau, d);
    if (e > best * (1 + 1e-9)) {
      best = e;
      best_delay = d;
    }
  }
  const double ratio = std::pow(50.0, 1.0 / (grid - 1));
  double lo = std::log(std::max(best_tau / ratio, tau_min)), hi = std::log(best_tau * ratio);
  const double gr = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = hi - gr * (hi - lo), x2 = lo + gr * (hi - lo);
  double f1 = spike_score(near, std::exp(x1), best_delay), f2 = spike_score(near, std::exp(x2), best_delay);
  for (int it = 0; it < 14; ++it) {
    if (f1 > f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - gr * (hi - lo);
      f1 = spike_score(near, std::exp(x1), best_delay);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + gr * (hi - lo);
      f2 = spike_score(near, std::exp(x2), best_delay);
    }
  }
  const double xm = 0.5 * (lo + hi);
  if (spike_score(near, std::exp(xm), best_delay) > best) best_tau = std::exp(xm);
  if (!(spike_score(near, best_tau, best_delay) > 30.0 * base.s2))
    return {std::max(assumed_spike_decay_s, 2 * dt), 0.0, 0.0, false};
  const auto [sur, suu] = spike_sums(near, best_tau, best_delay);
  return {best_tau, best_delay, suu > 0 ? sur / suu : 0.0, true};
}

// Reversal spikes: the decay time and delay of each axis that explain most of the preliminary residual.
void search_reversal_spikes(const std::vector<formats::DbbRun>& runs, const std::vector<Point>& pts,
                            const LsqResult& base, DiagLayout& L) {
  // Sample spacing: delays shorter than it cannot be told apart (ties keep the shortest).
  double dt = 1e9;
  for (const auto& run : runs)
    for (std::size_t i = 1; i < run.t_s.size(); ++i) dt = std::min(dt, std::max(run.t_s[i] - run.t_s[i - 1], 1e-4));
  // With samples further apart than 2 ms a delay only trades off against the height: not searched.
  const double delay_step = std::max(0.002, dt);
  const double delay_max = dt <= 0.002 ? 0.02 : 0.0;
  const SpikeShape a = search_spike(pts, base, true, delay_step, delay_max, dt);
  const SpikeShape b = search_spike(pts, base, false, delay_step, delay_max, dt);
  L.tau_a = a.tau;
  L.delay_a = a.delay;
  L.amp_a = a.amp;
  L.decay_a = a.significant;
  L.tau_b = b.tau;
  L.delay_b = b.delay;
  L.amp_b = b.amp;
  L.decay_b = b.significant;
  L.spikes = true;
}

// Cyclic error: the given period or the best of the usual ball-screw leads (at most r/4), per axis, kept
// only when it explains clearly more than noise (2 dof, about p < 1e-6).
void choose_cyclic_periods(const std::vector<formats::DbbRun>& runs, std::vector<Point>& pts, const LsqResult& base,
                           const IdentifyOptions& options, DiagLayout& L) {
  const double rmin =
      std::min_element(runs.begin(), runs.end(), [](const formats::DbbRun& a, const formats::DbbRun& b) {
        return a.radius_m < b.radius_m;
      })->radius_m;
  const std::vector<double> leads = {1, 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10, 12, 16, 20, 25, 32, 40};
  // Largest arc length between samples: a lead p is sampled at least 4 times per period when only every
  // stride-th point is used, stride = p / (4 * step).
  double step = 0;
  for (std::size_t i = 1; i < pts.size(); ++i)
    if (pts[i].run == pts[i - 1].run)
      step = std::max(step, pts[i].radius_m * std::abs(pts[i].zeta_rad - pts[i - 1].zeta_rad));
  const auto stride_for = [step](double p) {
    return step > 0 ? std::max<std::size_t>(1, static_cast<std::size_t>(p / (4 * step))) : std::size_t{1};
  };
  const auto pick = [&](double given, bool axis_a) {
    if (given > 0) return given;
    double best = 0, best_p = 0;
    for (double lead_mm : leads) {
      const double p = lead_mm * 1e-3;
      if (p > rmin / 4) break;
      const double e = explained(
          pts, base.residual,
          [p, axis_a](const Point& q, double& u1, double& u2) {
            const double th = 2 * pi * (axis_a ? q.a_m : q.b_m) / p;
            const double f = q.lambda * (axis_a ? q.c : q.s);
            double sn, cs;
            fast_sincos(th, sn, cs);  // only compared between leads: libm's last bit is not needed
            u1 = f * sn;
            u2 = f * cs;
          },
          stride_for(p));
      if (e > best) {
        best = e;
        best_p = p;
      }
    }
    return best > 30.0 * base.s2 ? best_p : 0.0;
  };
  L.period_a = pick(options.cyclic_period_a_m, true);
  L.period_b = pick(options.cyclic_period_b_m, false);
  L.cyclic_a = L.period_a > 0;
  L.cyclic_b = L.period_b > 0;
  set_cyclic_phases(L, pts);
}

// The diagnostics fit with the deadband of its own backlash (the points carry `shaped`, Lai's): its drive
// delay searched again with the diagnostics' terms (the spikes among them) in the fit, its width refitted
// when it differs noticeably from the one the points carry.
LsqResult fit_with_own_backlash(std::vector<Point>& pts, const std::vector<DriveTrack>& tracks,
                                const std::string& plane, DiagWork& work, Deadband shaped, const DiagLayout& L) {
  const auto fit = [&](Eigen::Index stride) {
    LsqResult res = fit_diag(L, pts, plane, work, stride);
    if (!res.ok) throw formats::DbbRunFormatError("identify: " + res.message);
    return res;
  };
  const auto own = [&](const LsqResult& res) {
    const std::size_t ga = L.global0() + DiagLayout::backlash_a;
    return Deadband{res.identified[ga] ? res.x[static_cast<Eigen::Index>(ga)] * 1e-6 : 0.0,
                    res.identified[ga + 1] ? res.x[static_cast<Eigen::Index>(ga + 1)] * 1e-6 : 0.0, shaped.track};
  };
  const auto differs = [](const Deadband& now, const Deadband& was) {
    const auto by = [](double n, double w) { return std::abs(n - w) > std::max(0.02 * std::abs(w), 0.02e-6); };
    return by(now.b_a, was.b_a) || by(now.b_b, was.b_b);
  };
  LsqResult res = fit(1);
  Deadband now = own(res);
  if (now.shaped() && tracks.size() > 1) {
    shaped = choose_deadband_delay(pts, tracks, now, [&](const std::vector<Point>&) { return fit(3).rms; });
    res = fit(1);
    now = own(res);
  }
  if (differs(now, shaped)) {
    set_deadband(pts, tracks[now.track], std::max(now.b_a, 0.0), std::max(now.b_b, 0.0));
    res = fit(1);
  }
  return res;
}

// Gauss-Newton iterations on the spike decay times (linear in everything else).
void refine_spike_decays(const std::vector<Point>& pts, const std::string& plane, DiagWork& work, DiagLayout& L,
                         LsqResult& res) {
  for (int it = 0; it < 4 && (L.decay_a || L.decay_b); ++it) {
    bool moved = false;
    const auto step = [&](bool on, std::size_t k_decay, std::size_t k_amp, double& tau, double& amp) {
      if (!on || !res.identified[k_decay]) return;
      const double d = res.x[static_cast<Eigen::Index>(k_decay)] * 1e-3;
      const double next = std::clamp(tau + d, 0.5 * tau, 2.0 * tau);
      if (std::abs(next - tau) > 0.002 * tau) moved = true;
      tau = next;
      amp = res.x[static_cast<Eigen::Index>(k_amp)];
    };
    step(L.decay_a, L.decay_a0(), L.spike0(), L.tau_a, L.amp_a);
    step(L.decay_b, L.decay_b0(), L.spike0() + 1, L.tau_b, L.amp_b);
    if (!moved) break;
    res = fit_diag(L, pts, plane, work);
    if (!res.ok) throw formats::DbbRunFormatError("identify: " + res.message);
  }
}

// The cyclic error of one plane axis as amplitude, period and phase (from its sine and cosine columns,
// the amplitude's u to first order); an amplitude 0 without u when none was fitted.
void add_cyclic_error(const LsqResult& res, bool on, std::size_t k0, double period, const std::string& plane, int axis,
                      std::vector<Estimate>& out) {
  if (!on) {
    out.push_back(est(results::name(results::cyclic_error, plane, axis), 0.0, nan, false));
    return;
  }
  if (!res.identified[k0] || !res.identified[k0 + 1]) return;
  const auto i0 = static_cast<Eigen::Index>(k0);
  const AmplitudePhase line = amplitude_phase(res.x[i0], res.x[i0 + 1], res.covariance(i0, i0),
                                              res.covariance(i0 + 1, i0 + 1), res.covariance(i0, i0 + 1));
  const double amp = line.amplitude, u = line.u_amplitude;
  out.push_back(est(results::name(results::cyclic_error, plane, axis), amp, u));
  out.push_back(est(results::name(results::cyclic_period, plane, axis), period * 1e3, nan, false));
  // The phase of an amplitude within 2 u of zero is noise's (it printed as e.g. 6e-10 deg): not reported.
  if (std::isfinite(u) && amp > 2 * u)
    out.push_back(est(results::name(results::cyclic_phase, plane, axis), line.phase_rad * 180 / pi, nan, false));
}

// The terms fitted beside (columns [first, end) of the fit) as reported: each identified column, then each
// line among them (a vibration's or cyclic error's sine and cosine parts) as its amplitude and phase, with
// u from the parts' covariance.
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

// The diagnostics as reported: the fitted terms identified, the scale mismatch, the cyclic errors, the
// spikes' decays and delays.
void report_diagnostics(const DiagLayout& L, const LsqResult& res, const std::vector<std::string>& names,
                        const std::string& plane, Identification& out) {
  const auto add = [&](std::size_t idx) {
    if (!res.identified[idx]) return;
    out.diagnostics.push_back(
        est(names[idx], res.x[static_cast<Eigen::Index>(idx)], res.u[static_cast<Eigen::Index>(idx)]));
  };
  for (std::size_t k = 0; k < 2 * L.runs; ++k) add(k);
  const std::size_t g = L.global0();
  add(g + DiagLayout::scale_a);
  add(g + DiagLayout::scale_b);
  if (res.identified[g + DiagLayout::scale_a] && res.identified[g + DiagLayout::scale_b]) {
    const auto ia = static_cast<Eigen::Index>(g + DiagLayout::scale_a);
    const auto ib = static_cast<Eigen::Index>(g + DiagLayout::scale_b);
    const double var = res.covariance(ia, ia) + res.covariance(ib, ib) - 2 * res.covariance(ia, ib);
    out.diagnostics.push_back(
        est(results::name(results::scale_mismatch), res.x[ia] - res.x[ib], std::sqrt(std::max(var, 0.0))));
  }
  for (auto k : {DiagLayout::squareness, DiagLayout::backlash_a, DiagLayout::backlash_b, DiagLayout::play_a,
                 DiagLayout::play_b, DiagLayout::servo, DiagLayout::bow_a, DiagLayout::bow_b, DiagLayout::cubic})
    add(g + k);
  add(L.spike0());
  add(L.spike0() + 1);
  add_cyclic_error(res, L.cyclic_a, L.cyc_a0(), L.period_a, plane, 0, out.diagnostics);
  add_cyclic_error(res, L.cyclic_b, L.cyc_b0(), L.period_b, plane, 1, out.diagnostics);
  const auto decay = [&](bool fitted, std::size_t k, double tau, int axis) {
    const std::string name = results::name(results::reversal_spike_decay, plane, axis);
    if (fitted && res.identified[k]) {
      out.diagnostics.push_back(
          est(name, tau * 1e3 + res.x[static_cast<Eigen::Index>(k)], res.u[static_cast<Eigen::Index>(k)]));
    } else {
      out.diagnostics.push_back(est(name, tau * 1e3, nan, false));
    }
  };
  decay(L.decay_a, L.decay_a0(), L.tau_a, 0);
  decay(L.decay_b, L.decay_b0(), L.tau_b, 1);
  out.diagnostics.push_back(est(results::name(results::reversal_spike_delay, plane, 0), L.delay_a * 1e3, nan, false));
  out.diagnostics.push_back(est(results::name(results::reversal_spike_delay, plane, 1), L.delay_b * 1e3, nan, false));
  add_beside(res, names, L.beside0(), L.beside0() + L.beside_count(), out.beside);
}

// The ballbar diagnostics of `runs` (points `pts`, carrying the deadband `shaped` on the drives' `tracks`):
// fills out.diagnostics, out.diagnostics_fit and out.ranking; returns the final fit.
LsqResult diagnose(const std::vector<formats::DbbRun>& runs, std::vector<Point>& pts,
                   const std::vector<DriveTrack>& tracks, const std::string& plane, DiagWork& work, Deadband shaped,
                   const IdentifyOptions& options, Identification& out) {
  DiagLayout L;
  L.runs = runs.size();
  const BesideColumns beside = beside_columns(options, true);
  L.beside = &beside;
  // Preliminary fit (a third of the points) whose residual steers the spike and cyclic searches.
  const LsqResult base = fit_diag(L, pts, plane, work, 3);
  if (!base.ok) throw formats::DbbRunFormatError("identify: " + base.message);
  search_reversal_spikes(runs, pts, base, L);
  choose_cyclic_periods(runs, pts, base, options, L);
  LsqResult res = fit_with_own_backlash(pts, tracks, plane, work, shaped, L);
  refine_spike_decays(pts, plane, work, L, res);
  out.diagnostics_fit = summary_of(res);
  const auto names = diag_names(L, plane);
  add_bar_length_uncertainty(res, work.j.leftCols(static_cast<Eigen::Index>(L.count())), work.w, names,
                             options.bar_length_u_um);
  report_diagnostics(L, res, names, plane, out);
  rank_contributions(L, res, pts, runs, names, plane, out);
  out.ranking_model = "diagnostics";
  return res;
}

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

// The error a Lai parameter describes, for the ranking: the two scales together (what they share is a
// radius, which the circle absorbs), the straightness coefficients by axis and direction.
std::string lai_error_group(const std::string& name) {
  const auto group = [](const results::Parameter& p) { return std::string(p.name); };
  if (name == results::lai_S_x.name || name == results::lai_S_y.name) return group(results::rank_scale_mismatch);
  if (name == results::lai_backlash_x.name) return group(results::rank_backlash_a);
  if (name == results::lai_backlash_y.name) return group(results::rank_backlash_b);
  if (name == results::lai_servo_mismatch.name) return group(results::rank_servo_mismatch);
  if (name == results::lai_c0_plus_d1.name) return group(results::rank_roll_b_straightness_an);
  switch (name.front()) {
    case 'a':
      return group(results::rank_straightness_ab);  // with the squareness a1
    case 'b':
      return group(results::rank_straightness_ba);
    case 'c':
      return group(results::rank_roll_b);
    case 'd':
      return group(results::rank_straightness_an);
    case 'e':
      return group(results::rank_straightness_bn);
    default:
      return name;
  }
}

// What Lai's fit leaves for the rest of identify().
struct LaiFit {
  std::vector<double> residual_rms;   // per run
  std::vector<Contribution> ranking;  // its terms' parts of G, largest first
  Deadband shaped;                    // the deadband whose shape the points carry (widths and the drives' delay)
};

// Lai's third-order model on every run (two passes: the first only estimates the backlash whose
// deadband shape, at the drives' delay that fits best, the second uses; `pts` keep that shape). Fills
// out.fit and out.lai3.
LaiFit fit_lai(const std::vector<formats::DbbRun>& runs, std::vector<Point>& pts, const std::vector<DriveTrack>& tracks,
               DiagWork& work, const IdentifyOptions& options, Identification& out) {
  const auto n = static_cast<Eigen::Index>(pts.size());
  LaiFit lai;
  lai.residual_rms.assign(runs.size(), 0.0);
  std::vector<std::size_t> counts(runs.size(), 0);
  const bool shared = options.lai_shared_center || runs.size() == 1;
  const std::size_t n_center = shared ? 2 : 2 * runs.size();
  const std::size_t m = lai_count - 2 + n_center;
  std::vector<std::string> names;
  if (shared) {
    names = lai3_parameter_names();
  } else {
    for (std::size_t k = 0; k < runs.size(); ++k) {
      names.push_back(results::run_prefixed(static_cast<int>(k + 1), results::name(results::lai_e_x)));
      names.push_back(results::run_prefixed(static_cast<int>(k + 1), results::name(results::lai_e_y)));
    }
    for (std::size_t c = 2; c < lai_count; ++c) names.emplace_back(lai_columns[c].parameter->name);
  }
  // The terms fitted beside Lai's, after them.
  const BesideColumns beside = beside_columns(options, false);
  names.insert(names.end(), beside.names.begin(), beside.names.end());
  const std::size_t cols = m + beside.size();
  // With stride > 1 only every stride-th point enters (its residual is not needed).
  const auto fit = [&](Eigen::Index stride) {
    const Eigen::Index rows = strided_rows(n, static_cast<Eigen::Index>(cols), stride);
    if (rows == n) stride = 1;
    auto j = work.j.topLeftCorner(rows, static_cast<Eigen::Index>(cols));
    if (!shared) j.setZero();
    Eigen::VectorXd ys(rows), ws(rows);
    double basis[lai_count];
    for (Eigen::Index i = 0; i < rows; ++i) {
      const Point& p = pts[static_cast<std::size_t>(i * stride)];
      lai_basis(p, basis);
      const std::size_t off = shared ? 0 : 2 * p.run;
      j(i, static_cast<Eigen::Index>(off)) = basis[0] * lai_columns[0].si_per_reported * 1e6;
      j(i, static_cast<Eigen::Index>(off + 1)) = basis[1] * lai_columns[1].si_per_reported * 1e6;
      for (std::size_t c = 2; c < lai_count; ++c)
        j(i, static_cast<Eigen::Index>(n_center + c - 2)) = basis[c] * lai_columns[c].si_per_reported * 1e6;
      for (std::size_t c = 0; c < beside.size(); ++c) j(i, static_cast<Eigen::Index>(m + c)) = beside.at(c, p);
      ys[i] = p.dL_um;
      ws[i] = p.w;
    }
    LsqResult r = solve_lsq(j, ys, ws, names);
    if (!r.ok) throw formats::DbbRunFormatError("identify: " + r.message);
    return r;
  };
  // First pass on a third of the points: only its backlash estimate is used (deadband shape).
  LsqResult res = fit(3);
  // Second pass with the deadband shape of the estimated backlash, at the drives' delay that fits best.
  const auto bx = static_cast<Eigen::Index>(n_center + 15), by = bx + 1;
  const Deadband step{res.identified[static_cast<std::size_t>(bx)] ? res.x[bx] * 1e-6 : 0.0,
                      res.identified[static_cast<std::size_t>(by)] ? res.x[by] * 1e-6 : 0.0};
  if (step.shaped())
    lai.shaped = choose_deadband_delay(pts, tracks, step, [&](const std::vector<Point>&) { return fit(3).rms; });
  res = fit(1);
  out.fit = summary_of(res);
  if (options.bar_length_u_um > 0) {
    Eigen::VectorXd w(n);
    for (Eigen::Index i = 0; i < n; ++i) w[i] = pts[static_cast<std::size_t>(i)].w;
    // Every column of the fit, the terms fitted beside included: the response is of the same model.
    add_bar_length_uncertainty(res, work.j.topLeftCorner(n, static_cast<Eigen::Index>(cols)), w, names,
                               options.bar_length_u_um);
  }
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double e = res.residual[static_cast<Eigen::Index>(i)];
    lai.residual_rms[pts[i].run] += e * e;
    counts[pts[i].run] += 1;
  }
  for (std::size_t k = 0; k < runs.size(); ++k)
    lai.residual_rms[k] = counts[k] ? std::sqrt(lai.residual_rms[k] / static_cast<double>(counts[k])) : 0.0;
  // Each error's part of the circular deviation, Lai's terms grouped as the errors they describe (the
  // two scales together: what they share is a radius, which the circle absorbs; the centre offset is
  // the set-up's).
  double g_max = 0;
  for (std::size_t k = 0, i = 0; k < runs.size(); i += runs[k].angle_rad.size(), ++k)
    g_max = std::max(g_max, circular_deviation(pts.data() + i, runs[k].angle_rad.size()));
  std::vector<std::string> groups;
  for (std::size_t c = n_center; c < m; ++c) {
    const std::string grp = lai_error_group(names[c]);
    if (res.identified[c] && std::find(groups.begin(), groups.end(), grp) == groups.end()) groups.push_back(grp);
  }
  double basis[lai_count];
  for (const auto& grp : groups) {
    std::vector<double> curve(pts.size(), 0.0);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      lai_basis(pts[i], basis);
      for (std::size_t c = n_center; c < m; ++c)
        if (res.identified[c] && lai_error_group(names[c]) == grp) {
          const std::size_t col = c - n_center + 2;
          curve[i] += basis[col] * lai_columns[col].si_per_reported * 1e6 * res.fitted[static_cast<Eigen::Index>(c)];
        }
    }
    const double part = part_of_deviation(pts, curve, runs.size());
    lai.ranking.push_back({grp, part, g_max > 0 ? 100 * part / g_max : nan});
  }
  std::sort(lai.ranking.begin(), lai.ranking.end(),
            [](const Contribution& a, const Contribution& b) { return a.contribution_um > b.contribution_um; });
  const double omega0 = runs.front().feed_m_per_s / runs.front().radius_m;
  for (std::size_t c = 0; c < m; ++c) {
    if (!res.identified[c]) continue;
    const auto ci = static_cast<Eigen::Index>(c);
    std::string name = names[c];
    double value = res.x[ci], u = res.u[ci];
    if (name == results::lai_S_x.name || name == results::lai_S_y.name) value += 1.0;
    if (name == results::lai_servo_mismatch.name) {
      // Lai's "mismatch phase angle": omega * delta tau, for the first run's angular velocity.
      out.lai3.push_back(est(results::name(results::lai_mismatch_phase_angle), value * 1e-3 * omega0 * 180 / pi,
                             u * 1e-3 * omega0 * 180 / pi));
    }
    out.lai3.push_back(est(name, value, u));
  }
  add_beside(res, names, m, cols, out.beside);
  return lai;
}

// The ballbar diagnostics, of the runs whose geometry they model (an in-plane bar, h = 0), with the
// deadband shape Lai's fit estimated. Fills out.diagnostics, out.notes and out.ranking; returns each
// run's residual RMS (NaN for the runs the diagnostics do not model).
std::vector<double> diagnose_in_plane_runs(const std::vector<formats::DbbRun>& runs, const std::string& plane,
                                           DiagWork& work, const LaiFit& lai, const IdentifyOptions& options,
                                           Identification& out) {
  std::vector<formats::DbbRun> flat;
  std::vector<std::size_t> flat_index;  // into runs
  for (std::size_t k = 0; k < runs.size(); ++k)
    if (std::abs(runs[k].height_m) < 1e-9) {
      flat.push_back(runs[k]);
      flat_index.push_back(k);
    }
  std::vector<double> residual_rms(runs.size(), nan);
  // Among runs with a socket height, the h = 0 ones must also go both ways: in one direction backlash,
  // play, spikes and servo mismatch trade off against errors the diagnostics do not model (a single
  // in-plane test of one machine error at a time is separable; Lai's three patterns are not).
  const bool both = std::any_of(flat.begin(), flat.end(),
                                [](const formats::DbbRun& r) { return r.direction == formats::DbbDirection::ccw; }) &&
                    std::any_of(flat.begin(), flat.end(),
                                [](const formats::DbbRun& r) { return r.direction == formats::DbbDirection::cw; });
  if (flat.empty()) {
    out.notes.push_back(
        "no ballbar diagnostics: they model an in-plane bar (h = 0) and every run has a socket height; "
        "Lai's model covers these runs (and ranks the errors)");
  } else if (!both && flat.size() < runs.size()) {
    out.notes.push_back(
        "no ballbar diagnostics: they need an in-plane (h = 0) test in both directions (backlash, play, "
        "spikes and servo mismatch are told apart by the direction), and the h = 0 runs go one way; "
        "Lai's model covers every run (and ranks the errors)");
  } else {
    if (flat.size() < runs.size()) {
      std::string which;
      for (const auto& r : flat) which += (which.empty() ? "" : ", ") + r.source;
      out.notes.push_back("ballbar diagnostics from the h = 0 run(s) only (" + which +
                          "): they model an in-plane bar, not a socket height; Lai's model above uses every run");
    }
    std::vector<std::size_t> first(runs.size(), 0);  // of each run among all the runs
    for (std::size_t k = 1; k < runs.size(); ++k) first[k] = first[k - 1] + runs[k - 1].angle_rad.size();
    std::vector<std::size_t> flat_first;
    for (const std::size_t k : flat_index) flat_first.push_back(first[k]);
    std::vector<Point> flat_pts = points_of(flat, flat_first);
    const std::vector<DriveTrack> tracks =
        drive_tracks(flat_pts, drive_delays_s(runs));  // Lai's delays: its track index holds
    if (lai.shaped.shaped()) set_deadband(flat_pts, tracks[lai.shaped.track], lai.shaped.b_a, lai.shaped.b_b);
    const LsqResult res = diagnose(flat, flat_pts, tracks, plane, work, lai.shaped, options, out);
    // Absolute scales that agree are a radius change common to both axes, not the axes' scales.
    const auto find = [&](const std::string& name) -> const Estimate* {
      for (const auto& e : out.diagnostics)
        if (e.name == name) return &e;
      return nullptr;
    };
    const Estimate* sa = find(results::name(results::scale, plane, 0));
    const Estimate* sb = find(results::name(results::scale, plane, 1));
    if (sa && sb) {
      const double common = 0.5 * (sa->value + sb->value), mismatch = sa->value - sb->value;
      if (std::abs(common) > 50 && std::abs(common) > 3 * std::abs(mismatch)) {
        std::ostringstream o;
        o << "both axes' scales read about " << std::lround(common)
          << " ppm: a radius change common to both (a position "
          << "loop's lag tau shrinks a circle by r (omega tau)^2 / 2 at high feed, 346 ppm for 30 ms at 5000 mm/min on "
          << "95 mm; a bar calibration error) rather than the axes' own scales; "
          << results::name(results::scale_mismatch) << " (" << std::lround(mismatch) << " ppm) is the axes' difference";
        out.notes.push_back(o.str());
      }
    }
    for (std::size_t k = 0; k < flat.size(); ++k) {
      double ss = 0;
      std::size_t cnt = 0;
      for (std::size_t i = 0; i < flat_pts.size(); ++i)
        if (flat_pts[i].run == k) {
          ss += res.residual[static_cast<Eigen::Index>(i)] * res.residual[static_cast<Eigen::Index>(i)];
          ++cnt;
        }
      residual_rms[flat_index[k]] = cnt ? std::sqrt(ss / static_cast<double>(cnt)) : nan;
    }
  }
  return residual_rms;
}

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
  std::vector<Point> pts = points_of(runs);
  std::size_t beside = 0;
  for (const BesideTerm& t : options.beside) {
    for (const auto& c : t.columns_um)
      if (c.size() != pts.size())
        throw formats::DbbRunFormatError("identify: the column of " + t.effect + " fitted beside has " +
                                         std::to_string(c.size()) + " values for " + std::to_string(pts.size()) +
                                         " samples");
    beside += t.columns_um.size();
  }
  DiagWork work;
  // Widest fit: the Lai model with per-run centres or the diagnostics with every optional term
  // (spikes 2, decays 2, cyclic 4), and the terms fitted beside.
  work.j.resize(static_cast<Eigen::Index>(pts.size()),
                static_cast<Eigen::Index>(2 * runs.size() +
                                          std::max<std::size_t>(lai_count - 2, DiagLayout::n_base + 8) + beside));
  const LaiFit lai = fit_lai(runs, pts, drive_tracks(pts, drive_delays_s(runs)), work, options, out);
  const std::vector<double> residual_rms = diagnose_in_plane_runs(runs, plane, work, lai, options, out);
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
