// Lai's third-order guideway model fitted to DBB runs (lai_fit.hpp).
#include "models/dbb/lai_fit.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "results/parameters.hpp"

namespace guideway::models::dbb::fitting {

namespace {

struct LaiColumn {
  const results::Parameter* parameter;
  double si_per_reported;  // SI value of one reported unit
  int axis = -1;           // Lai's axis a (0) or b (1) of a quantity reported per axis (the backlash)
  // The name Lai's model reports it by (results/parameters.hpp: its own, or its entry's place in lai3).
  [[nodiscard]] std::string name() const { return results::name_in(*parameter, results::lai3_group, "xy", axis); }
};

// Order matters: lai3_characteristics returns the basis in this order.
constexpr LaiColumn lai_columns[] = {
    {&results::lai_e_x, 1e-6},       {&results::lai_e_y, 1e-6},        {&results::lai_S_x, 1.0},
    {&results::lai_S_y, 1.0},        {&results::lai_a1, 1.0},          {&results::lai_a2, 1e3},
    {&results::lai_a3, 1e6},         {&results::lai_b2, 1e3},          {&results::lai_b3, 1e6},
    {&results::lai_c0_plus_d1, 1.0}, {&results::lai_c1, 1e3},          {&results::lai_c2, 1e6},
    {&results::lai_d2, 1e3},         {&results::lai_d3, 1e6},          {&results::lai_e1, 1.0},
    {&results::lai_e2, 1e3},         {&results::lai_e3, 1e6},          {&results::backlash, 1e-6, 0},
    {&results::backlash, 1e-6, 1},   {&results::servo_mismatch, 1e-3},
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

// The error a Lai parameter describes, for the ranking: the two scales together (what they share is a
// radius, which the circle absorbs), the straightness coefficients by axis and direction.
std::string lai_error_group(const std::string& name) {
  const auto group = [](const results::Parameter& p, int axis = -1) {
    return results::name_in(p, results::ranking_group, "xy", axis);
  };
  const auto lai = [](const results::Parameter& p, int axis = -1) {
    return results::name_in(p, results::lai3_group, "xy", axis);
  };
  if (name == results::lai_S_x.name || name == results::lai_S_y.name) return group(results::scale_mismatch);
  if (name == lai(results::backlash, 0)) return group(results::backlash, 0);
  if (name == lai(results::backlash, 1)) return group(results::backlash, 1);
  if (name == lai(results::servo_mismatch)) return group(results::servo_mismatch);
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

}  // namespace

std::size_t lai_column_count() { return lai_count; }

// Lai's third-order model on every run (two passes: the first only estimates the backlash whose
// deadband shape, at the drives' delay that fits best, the second uses; `pts` keep that shape). Fills
// out.fit and out.lai3.
LaiFit fit_lai(const std::vector<formats::DbbRun>& runs, std::vector<Point>& pts, const std::vector<DriveTrack>& tracks,
               FitWork& work, const IdentifyOptions& options, Identification& out) {
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
    for (std::size_t c = 2; c < lai_count; ++c) names.push_back(lai_columns[c].name());
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
    return solved(solve_lsq(j, ys, ws, names));
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
  std::vector<std::string> group_of(m);  // each column's, named once: not in the loop over the points
  for (std::size_t c = n_center; c < m; ++c) {
    group_of[c] = lai_error_group(names[c]);
    if (res.identified[c] && std::find(groups.begin(), groups.end(), group_of[c]) == groups.end())
      groups.push_back(group_of[c]);
  }
  double basis[lai_count];
  for (const auto& grp : groups) {
    std::vector<double> curve(pts.size(), 0.0);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      lai_basis(pts[i], basis);
      for (std::size_t c = n_center; c < m; ++c)
        if (res.identified[c] && group_of[c] == grp) {
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
    if (name == results::name_in(results::servo_mismatch, results::lai3_group)) {
      // Lai's "mismatch phase angle": omega * delta tau, for the first run's angular velocity.
      out.lai3.push_back(est(results::name(results::lai_mismatch_phase_angle), value * 1e-3 * omega0 * 180 / pi,
                             u * 1e-3 * omega0 * 180 / pi));
    }
    out.lai3.push_back(est(name, value, u));
  }
  add_beside(res, names, m, cols, out.beside);
  return lai;
}

}  // namespace guideway::models::dbb::fitting

namespace guideway::models::dbb {

using fitting::lai_basis;
using fitting::lai_columns;
using fitting::lai_count;
using fitting::Point;
using fitting::set_step_backlash;

std::vector<std::string> lai3_parameter_names() {
  std::vector<std::string> n;
  for (const auto& c : lai_columns) n.push_back(c.name());
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

}  // namespace guideway::models::dbb
