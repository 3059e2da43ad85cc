// One model of the machine from the day's tests (fit.hpp): every test's readings fitted together through the chain.
#include "models/map/fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>

#include "core/number_format.hpp"
#include "core/units.hpp"
#include "models/map/fit_groups.hpp"

namespace guideway::models::map {

namespace {

using detail::Group;
using detail::GroupKind;
using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

Index ix(std::size_t i) { return static_cast<Index>(i); }

// ---- What the day's tests can see ----

struct Coverage {
  std::array<bool, 3> artifact{}, traverse_pitch{}, traverse_yaw{};
  std::set<std::string> planes;
};

Coverage coverage_of(const MapInputs& in) {
  Coverage c;
  for (const auto& a : in.artifacts) c.artifact[static_cast<std::size_t>(a.axis)] = true;
  for (const auto& t : in.traverses) {
    c.traverse_pitch[static_cast<std::size_t>(t.axis)] = true;
    if (!t.yaw_rad.empty()) c.traverse_yaw[static_cast<std::size_t>(t.axis)] = true;
  }
  for (const auto& r : in.ballbar_runs) c.planes.insert(r.plane);
  return c;
}

std::string upper(int axis) { return std::string(1, "XYZ"[axis]); }

// Why a function no test of the day saw is not in the map, and what would determine it.
std::string why_not(int j, int c) {
  const std::string a = upper(j);
  switch (role_of(j, c)) {
    case Role::positioning:
      return "no test of the day measures the positioning of " + a + " along its travel (the ballbar sees only the "
             "difference of two axes' scales, over its circle): a laser interferometer along " + a +
             " (ISO 230-2) or the 1-D artifact on " + a + " determines it";
    case Role::straightness:
      return "no test of the day measures the straightness of " + a + " in " + axis_name(c) +
             " over its travel (the ballbar sees it over its circle only; the autocollimator reads angles, a "
             "straightness only for a bent guideway): the 1-D artifact on " + a +
             ", a straightedge with an indicator or a laser straightness optic determines it";
    case Role::roll:
      if (j == 2)
        return "no test of the day measures the roll of Z (an autocollimator looking along Z cannot see a rotation "
               "about its beam, and no level sees the roll of a vertical axis): the 1-D artifact on Z, or a square "
               "with two indicators at two heights, determines it";
      return "no test of the day measures the roll of " + a + " (an autocollimator looking along " + a +
             " cannot see a rotation about its beam): an electronic level on the " + a +
             " carriage (readings along the travel), or the 1-D artifact on " + a + ", determines it";
    case Role::pitch:
    case Role::yaw:
      return "no test of the day measures the " + role_name(role_of(j, c)) + " of " + a +
             ": an autocollimator traverse of " + a + " (guideway start straightness --option axis=" +
             axis_name(j) + ") or the 1-D artifact on " + a + " determines it";
  }
  return "";
}

// The tests that see a function, or "" when none does.
std::string seen_by(const Coverage& cv, int j, int c) {
  const auto J = static_cast<std::size_t>(j);
  const Role role = role_of(j, c);
  std::vector<std::string> by;
  if (role == Role::pitch || role == Role::yaw) {
    const bool traverse = role == Role::pitch ? cv.traverse_pitch[J] : cv.traverse_yaw[J];
    if (traverse) by.push_back("traverse " + upper(j));
  }
  if (cv.artifact[J]) by.push_back("artifact " + upper(j));
  std::string s;
  for (const auto& b : by) s += (s.empty() ? "" : " + ") + b;
  return s;
}

// How many distinct positions the tests along an axis read (the richest one): the orders it can carry.
int positions_along(const MapInputs& in, int j, bool angles_only) {
  std::size_t n = 0;
  for (const auto& a : in.artifacts)
    if (a.axis == j) n = std::max(n, a.position_m.size());
  if (angles_only)
    for (const auto& t : in.traverses)
      if (t.axis == j) n = std::max(n, std::set<double>(t.position_m.begin(), t.position_m.end()).size());
  return static_cast<int>(n);
}

std::array<Travel, 3> travel_of(const MapInputs& in) {
  if (in.travel) return *in.travel;
  std::array<Travel, 3> t{};
  std::array<bool, 3> have{};
  const auto add = [&](int j, double u) {
    auto& tr = t[static_cast<std::size_t>(j)];
    if (!have[static_cast<std::size_t>(j)]) {
      tr = {u, u};
      have[static_cast<std::size_t>(j)] = true;
    }
    tr.lo_m = std::min(tr.lo_m, u);
    tr.hi_m = std::max(tr.hi_m, u);
  };
  for (const auto& a : in.artifacts)
    for (double u : a.position_m) add(a.axis, u);
  for (const auto& tv : in.traverses)
    for (double u : tv.position_m) add(tv.axis, u);
  // An axis no test runs along: the ballbar circles' extent.
  for (const auto& r : in.ballbar_runs) {
    const auto ax = plane_axes(r.plane);
    if (!have[static_cast<std::size_t>(ax[0])] || t[static_cast<std::size_t>(ax[0])].length_m() == 0) {
      add(ax[0], r.center_a_m - r.radius_m);
      add(ax[0], r.center_a_m + r.radius_m);
    }
    if (!have[static_cast<std::size_t>(ax[1])] || t[static_cast<std::size_t>(ax[1])].length_m() == 0) {
      add(ax[1], r.center_b_m - r.radius_m);
      add(ax[1], r.center_b_m + r.radius_m);
    }
  }
  for (std::size_t j = 0; j < 3; ++j)
    if (!(t[j].length_m() > 0)) t[j] = {t[j].lo_m - 0.05, t[j].hi_m + 0.05};
  return t;
}

// ---- The normal equations of every group ----

struct Blocks {
  std::size_t p = 0;   // map parameters
  std::size_t nu = 0;  // every group's own terms
  std::vector<std::unique_ptr<Group>> groups;
  std::vector<std::size_t> first_nuisance;  // per group, global column
  std::vector<MatrixXd> jac;                // per group: rows x (p + its nuisance)
  std::vector<VectorXd> w;                  // per group: 1 / sigma^2 of each reading (relative)
  std::vector<MatrixXd> a;                  // J^T W J, (p + its nuisance)^2
  std::vector<double> scale2;               // per group: estimated variance factor
  [[nodiscard]] std::size_t columns() const { return p + nu; }
  // Global column of a group's local column.
  [[nodiscard]] std::size_t global(std::size_t g, std::size_t local) const {
    return local < p ? local : first_nuisance[g] + (local - p);
  }
};

Blocks make_blocks(const MapInputs& in, const ErrorMap& m, const FitOptions& o,
                   const detail::DeadbandWidths& deadbands = {}) {
  Blocks b;
  b.p = m.parameters;
  b.groups = detail::make_groups(in, m, o.ballbar_samples_per_run, deadbands);
  std::size_t next = b.p;
  for (const auto& g : b.groups) {
    b.first_nuisance.push_back(next);
    next += g->nuisance();
    MatrixXd j;
    g->jacobian(m, j);
    VectorXd w(ix(g->rows()));
    for (std::size_t i = 0; i < g->rows(); ++i) w[ix(i)] = 1.0 / (g->sigma[i] * g->sigma[i]);
    b.a.push_back(j.transpose() * w.asDiagonal() * j);
    b.jac.push_back(std::move(j));
    b.w.push_back(std::move(w));
    b.scale2.push_back(1.0);
  }
  b.nu = next - b.p;
  return b;
}

// A group's columns of the global parameters: the map's, then its own.
VectorXd local_theta(const Blocks& b, std::size_t g, const VectorXd& theta) {
  const std::size_t local = b.p + b.groups[g]->nuisance();
  VectorXd t(ix(local));
  for (std::size_t k = 0; k < local; ++k) t[ix(k)] = theta[ix(b.global(g, k))];
  return t;
}

// The linearised readings at parameters theta (global): y - f(theta) + J theta, per group.
std::vector<VectorXd> pseudo_readings(const Blocks& b, ErrorMap& m, const VectorXd& theta) {
  std::vector<double> mp(b.p);
  for (std::size_t k = 0; k < b.p; ++k) mp[k] = theta[ix(k)];
  m.set_parameters(mp);
  std::vector<VectorXd> out;
  for (std::size_t g = 0; g < b.groups.size(); ++g) {
    const Group& gr = *b.groups[g];
    const std::size_t ng = gr.nuisance();
    std::vector<double> nu(ng);
    const VectorXd local = local_theta(b, g, theta);
    for (std::size_t k = 0; k < ng; ++k) nu[k] = local[ix(b.p + k)];
    std::vector<double> f(gr.rows());
    gr.predict(m, nu.data(), f.data());
    VectorXd y(ix(gr.rows()));
    for (std::size_t i = 0; i < gr.rows(); ++i) y[ix(i)] = gr.y[i] - f[i];
    out.push_back(y + b.jac[g] * local);
  }
  return out;
}

// The normal equations of every group together (with the groups' estimated scales), on all columns.
struct Normal {
  MatrixXd n;
  VectorXd rhs;
  double yy = 0.0;  // sum of the weighted squared readings
};

Normal normal_of(const Blocks& b, const std::vector<VectorXd>& y, const std::vector<bool>& use_group = {}) {
  Normal out;
  out.n = MatrixXd::Zero(ix(b.columns()), ix(b.columns()));
  out.rhs = VectorXd::Zero(ix(b.columns()));
  for (std::size_t g = 0; g < b.groups.size(); ++g) {
    if (!b.groups[g]->in_fit || (!use_group.empty() && !use_group[g])) continue;
    const double s = 1.0 / b.scale2[g];
    const VectorXd wy = b.w[g].asDiagonal() * y[g];
    const VectorXd c = b.jac[g].transpose() * wy;
    out.yy += s * y[g].dot(wy);
    const std::size_t local = b.p + b.groups[g]->nuisance();
    for (std::size_t r = 0; r < local; ++r) {
      const std::size_t R = b.global(g, r);
      out.rhs[ix(R)] += s * c[ix(r)];
      for (std::size_t q = 0; q < local; ++q) out.n(ix(R), ix(b.global(g, q))) += s * b.a[g](ix(r), ix(q));
    }
  }
  return out;
}

MatrixXd sub_matrix(const MatrixXd& m, const std::vector<std::size_t>& cols) {
  MatrixXd out(ix(cols.size()), ix(cols.size()));
  for (std::size_t r = 0; r < cols.size(); ++r)
    for (std::size_t c = 0; c < cols.size(); ++c) out(ix(r), ix(c)) = m(ix(cols[r]), ix(cols[c]));
  return out;
}

// chi2 (with the scales) of the least-squares solution on `cols`: yy - b' N^-1 b, by Cholesky of the scaled
// normal matrix (the order search's many small solves).
double chi2_on(const Normal& nm, const std::vector<std::size_t>& cols) {
  const MatrixXd n = sub_matrix(nm.n, cols);
  VectorXd rhs(ix(cols.size()));
  for (std::size_t k = 0; k < cols.size(); ++k) rhs[ix(k)] = nm.rhs[ix(cols[k])];
  VectorXd d(n.rows());
  for (Index k = 0; k < n.rows(); ++k) d[k] = n(k, k) > 0 ? 1.0 / std::sqrt(n(k, k)) : 1.0;
  const Eigen::LDLT<MatrixXd> ldlt(d.asDiagonal() * n * d.asDiagonal());
  const VectorXd x = ldlt.solve(d.asDiagonal() * rhs);
  return nm.yy - (d.asDiagonal() * rhs).dot(x);
}

// The solution on the selected columns (global, ascending) and what goes with it.
struct Solution {
  std::vector<std::size_t> cols;
  VectorXd theta;     // global length, zero outside cols
  MatrixXd inverse;   // of the normal matrix on cols (the covariance, with the estimated scales)
  std::vector<double> chi2;     // per group, relative weights (sum w r^2 without the scale)
  std::vector<double> trace;    // per group: its share of the fitted parameters
  std::size_t rank_deficiency = 0;  // directions the tests cannot see, left out
};

Solution solve(const Blocks& b, const std::vector<VectorXd>& y, const std::vector<std::size_t>& cols,
               const std::vector<bool>& use_group = {}) {
  const Normal nm = normal_of(b, y, use_group);
  const std::size_t n = cols.size();
  const MatrixXd sub = sub_matrix(nm.n, cols);
  VectorXd rhs(ix(n));
  for (std::size_t k = 0; k < n; ++k) rhs[ix(k)] = nm.rhs[ix(cols[k])];
  // Column scaling, then a symmetric eigen-decomposition: a singular direction is dropped, not inverted.
  VectorXd d(ix(n));
  for (std::size_t k = 0; k < n; ++k) d[ix(k)] = sub(ix(k), ix(k)) > 0 ? 1.0 / std::sqrt(sub(ix(k), ix(k))) : 1.0;
  Eigen::SelfAdjointEigenSolver<MatrixXd> eig(d.asDiagonal() * sub * d.asDiagonal());
  const VectorXd ev = eig.eigenvalues();
  const double top = ev.size() ? ev.maxCoeff() : 0.0;
  VectorXd inv_ev(ev.size());
  Solution s;
  for (Index k = 0; k < ev.size(); ++k) {
    inv_ev[k] = ev[k] > 1e-13 * top ? 1.0 / ev[k] : 0.0;
    if (inv_ev[k] == 0.0) ++s.rank_deficiency;
  }
  s.cols = cols;
  s.inverse = d.asDiagonal() * (eig.eigenvectors() * inv_ev.asDiagonal() * eig.eigenvectors().transpose()) *
              d.asDiagonal();
  const VectorXd x = s.inverse * rhs;
  s.theta = VectorXd::Zero(ix(b.columns()));
  for (std::size_t k = 0; k < n; ++k) s.theta[ix(cols[k])] = x[ix(k)];
  std::vector<long> where(b.columns(), -1);
  for (std::size_t k = 0; k < n; ++k) where[cols[k]] = static_cast<long>(k);
  for (std::size_t g = 0; g < b.groups.size(); ++g) {
    const std::size_t local = b.p + b.groups[g]->nuisance();
    const VectorXd r = y[g] - b.jac[g] * local_theta(b, g, s.theta);
    s.chi2.push_back(r.dot(b.w[g].asDiagonal() * r));
    double tr = 0.0;
    if (b.groups[g]->in_fit && (use_group.empty() || use_group[g]))
      for (std::size_t r1 = 0; r1 < local; ++r1) {
        const long R = where[b.global(g, r1)];
        if (R < 0) continue;
        for (std::size_t q = 0; q < local; ++q) {
          const long Q = where[b.global(g, q)];
          if (Q >= 0) tr += s.inverse(R, Q) * b.a[g](ix(q), ix(r1));
        }
      }
    s.trace.push_back(tr / b.scale2[g]);
  }
  return s;
}

// Each group's variance factor from its own residuals: chi2 / (readings - its share of the parameters).
void update_scales(Blocks& b, const Solution& s) {
  for (std::size_t g = 0; g < b.groups.size(); ++g) {
    if (!b.groups[g]->in_fit) continue;
    const double dof = std::max(1.0, static_cast<double>(b.groups[g]->rows()) - s.trace[g]);
    b.scale2[g] = std::max(s.chi2[g] / dof, b.groups[g]->stated_sigma ? 1.0 : 1e-12);
  }
}

// ---- The functions' columns in the max-order layout ----

struct FunctionColumns {
  int axis = 0, component = 0;
  std::size_t first = 0;  // global column of its lowest order
  int lowest = 1, highest = 1;
  int chosen = 1;
  double bic_n = 1.0;  // observations that see it (BIC's n)
};

std::vector<std::size_t> selected_columns(const Blocks& b, const std::vector<FunctionColumns>& fc,
                                          const ErrorMap& m) {
  std::vector<std::size_t> cols;
  for (const auto& f : fc)
    for (int k = f.lowest; k <= f.chosen; ++k) cols.push_back(f.first + static_cast<std::size_t>(k - f.lowest));
  for (const auto& q : m.squareness)
    if (q.parameter != no_parameter) cols.push_back(q.parameter);
  for (std::size_t k = b.p; k < b.columns(); ++k) cols.push_back(k);
  std::sort(cols.begin(), cols.end());
  return cols;
}

// ---- Squareness a ballbar cannot tell from an error no test determined ----

// For each plane with runs: the undetermined functions whose signature on the plane's readings (less its own
// set-up terms) is correlated with the squareness' by more than 0.1: the ballbar reads them together.
std::map<std::string, std::vector<std::string>> confounders(const MapInputs& in, const ErrorMap& fitted,
                                                            const FitOptions& o) {
  std::map<std::string, std::vector<std::string>> out;
  if (in.ballbar_runs.empty()) return out;
  ErrorMap probe = fitted;
  std::vector<std::pair<int, int>> hidden;
  for (int j = 0; j < 3; ++j)
    for (int c = 0; c < components; ++c) {
      ErrorFunction& f = probe.function(j, c);
      if (!f.determined) hidden.emplace_back(j, c);
      f.determined = true;
      f.orders.clear();
      for (int k = lowest_order(j, c); k <= 3; ++k) f.orders.push_back(k);
    }
  for (auto& q : probe.squareness) q.determined = true;
  assign_parameters(probe);
  if (hidden.empty()) return out;
  MapInputs only = in;
  only.artifacts.clear();
  only.traverses.clear();
  const auto groups = detail::make_groups(only, probe, std::min<std::size_t>(o.ballbar_samples_per_run, 360));
  for (const auto& g : groups) {
    MatrixXd j;
    g->jacobian(probe, j);
    const std::size_t p = probe.parameters;
    const MatrixXd nuis = j.rightCols(ix(g->nuisance()));
    const Eigen::ColPivHouseholderQR<MatrixXd> qr(nuis);
    const auto project = [&](const VectorXd& col) -> VectorXd { return col - nuis * qr.solve(col); };
    const int qi = squareness_index(g->plane);
    const VectorXd q = project(j.col(ix(probe.squareness[static_cast<std::size_t>(qi)].parameter)));
    if (!(q.norm() > 0)) continue;
    for (const auto& [a, c] : hidden) {
      const ErrorFunction& f = probe.function(a, c);
      double worst = 0.0;
      for (std::size_t k = 0; k < f.orders.size(); ++k) {
        const VectorXd col = project(j.col(ix(f.first_parameter + k)));
        if (col.norm() > 1e-12 * q.norm()) worst = std::max(worst, std::abs(col.dot(q)) / (col.norm() * q.norm()));
      }
      (void)p;
      if (worst > 0.1) out[g->plane].push_back(function_name(a, c));
    }
  }
  return out;
}

// ---- Cross-checks ----

// A function's estimate from one group alone (its own columns and the group's terms; every other map term
// held at the joint fit's value): coefficients and covariance.
struct OneSource {
  bool ok = false;
  VectorXd coefficients;
  MatrixXd covariance;
};

OneSource from_group(const Blocks& b, const std::vector<VectorXd>& y, const Solution& joint, std::size_t g,
                     const FunctionColumns& f) {
  const std::size_t local = b.p + b.groups[g]->nuisance();
  std::vector<std::size_t> own;  // local columns fitted here
  for (int k = f.lowest; k <= f.chosen; ++k) own.push_back(f.first + static_cast<std::size_t>(k - f.lowest));
  for (std::size_t k = b.p; k < local; ++k) own.push_back(k);
  std::vector<bool> is_own(local, false);
  for (std::size_t k : own) is_own[k] = true;
  VectorXd rhs_y = y[g];
  for (std::size_t k = 0; k < b.p; ++k)
    if (!is_own[k]) rhs_y -= b.jac[g].col(ix(k)) * joint.theta[ix(k)];
  MatrixXd jo(b.jac[g].rows(), ix(own.size()));
  for (std::size_t k = 0; k < own.size(); ++k) jo.col(ix(k)) = b.jac[g].col(ix(own[k]));
  const MatrixXd nm = jo.transpose() * b.w[g].asDiagonal() * jo / b.scale2[g];
  const VectorXd rhs = jo.transpose() * (b.w[g].asDiagonal() * rhs_y) / b.scale2[g];
  const Eigen::FullPivLU<MatrixXd> lu(nm);
  OneSource out;
  if (!lu.isInvertible()) return out;
  const MatrixXd inv = lu.inverse();
  const VectorXd x = inv * rhs;
  const std::size_t nf = static_cast<std::size_t>(f.chosen - f.lowest + 1);
  out.ok = true;
  out.coefficients = x.head(ix(nf));
  out.covariance = inv.topLeftCorner(ix(nf), ix(nf));
  return out;
}

// RMS over the travel of the difference of two estimates of a function, and its u.
CrossCheck compare_functions(const ErrorMap& m, const FunctionColumns& f, const OneSource& s1, const OneSource& s2,
                             const std::string& first, const std::string& second) {
  CrossCheck c;
  const Role role = role_of(f.axis, f.component);
  c.name = role_name(role) + " of " + upper(f.axis) + " (" + function_name(f.axis, f.component) + ")";
  c.first = first;
  c.second = second;
  const bool angle = f.component >= 3;
  c.unit = angle ? "urad" : "um";
  const double scale = 1e6;
  const Travel& tr = m.travel[static_cast<std::size_t>(f.axis)];
  const int n = 101;
  double d2 = 0, u2 = 0, v1 = 0, v2 = 0, uu1 = 0, uu2 = 0;
  std::vector<double> p(static_cast<std::size_t>(f.chosen) + 1);
  for (int i = 0; i < n; ++i) {
    const double u = tr.lo_m + tr.length_m() * i / (n - 1);
    legendre(tr.xi(u), f.chosen, p.data());
    VectorXd phi(f.chosen - f.lowest + 1);
    for (int k = f.lowest; k <= f.chosen; ++k) phi[k - f.lowest] = p[static_cast<std::size_t>(k)];
    const double a = phi.dot(s1.coefficients), b = phi.dot(s2.coefficients);
    const double va = phi.dot(s1.covariance * phi), vb = phi.dot(s2.covariance * phi);
    d2 += (a - b) * (a - b);
    u2 += va + vb;
    v1 += a * a;
    v2 += b * b;
    uu1 += va;
    uu2 += vb;
  }
  c.difference = std::sqrt(d2 / n) * scale;
  c.u_difference = std::sqrt(u2 / n) * scale;
  c.value_first = std::sqrt(v1 / n) * scale;
  c.value_second = std::sqrt(v2 / n) * scale;
  c.u_first = std::sqrt(uu1 / n) * scale;
  c.u_second = std::sqrt(uu2 / n) * scale;
  c.consistent = c.difference <= 2.0 * c.u_difference;
  c.note = "RMS over the travel; the difference's RMS against twice its u";
  return c;
}



// ---- The fit, step by step ----

// The map to fill: which functions and squarenesses the day's tests see, the orders each may carry, and the
// parameters of those (at the highest orders).
ErrorMap structure(const MapInputs& in, const FitOptions& o) {
  const Coverage cv = coverage_of(in);
  ErrorMap m = empty_map(travel_of(in), in.tool_offset_m);
  m.machine = in.machine;
  // Which functions the tests see, and the orders each may carry.
  for (int j = 0; j < 3; ++j)
    for (int c = 0; c < components; ++c) {
      ErrorFunction& f = m.function(j, c);
      f.determined_by = seen_by(cv, j, c);
      f.determined = !f.determined_by.empty();
      if (!f.determined) {
        f.why = why_not(j, c);
        continue;
      }
      const int lo = lowest_order(j, c);
      // An artifact's displacements carry an offset and (across) an alignment slope of their own.
      // At most half as many orders as positions read, so a function never follows the readings' noise.
      const int n_pos = positions_along(in, j, c >= 3);
      const int hi = std::min(o.max_order, (n_pos - 1) / 2);
      if (hi < lo) {
        f.determined = false;
        f.why = "the tests along " + upper(j) + " read too few positions (" + std::to_string(n_pos) +
                ") for its " + role_name(role_of(j, c));
        continue;
      }
      for (int k = lo; k <= hi; ++k) f.orders.push_back(k);
    }
  for (auto& q : m.squareness) {
    if (cv.planes.count(q.plane) == 0) {
      q.why = "no ballbar test in the " + q.plane + " plane: the ballbar in " + q.plane +
              " (guideway start dbb --test three-plane) or a square with an indicator determines it";
      continue;
    }
    q.determined = true;
    q.determined_by = "ballbar " + q.plane;
  }
  // A plane whose squareness the ballbar reads together with an error no test determined.
  for (const auto& [plane, hidden] : confounders(in, m, o)) {
    auto& q = m.squareness[static_cast<std::size_t>(squareness_index(plane))];
    if (!q.determined) continue;
    std::string names;
    for (const auto& h : hidden) names += (names.empty() ? "" : ", ") + h;
    q.determined = false;
    q.why = "the ballbar in " + plane + " reads the squareness of the axes' lines over its circle, which the map cannot "
            "tell from " + names + " (not determined by the day's tests: see each): determine " +
            (hidden.size() > 1 ? "them" : "it") + " too";
  }
  assign_parameters(m);
  return m;
}

std::vector<FunctionColumns> function_columns(const ErrorMap& m) {
  std::vector<FunctionColumns> fc;
  for (int j = 0; j < 3; ++j)
    for (int c = 0; c < components; ++c) {
      const ErrorFunction& f = m.function(j, c);
      if (f.first_parameter == no_parameter) continue;
      FunctionColumns col;
      col.axis = j;
      col.component = c;
      col.first = f.first_parameter;
      col.lowest = f.orders.front();
      col.highest = f.orders.back();
      col.chosen = col.highest;
      fc.push_back(col);
    }
  return fc;
}

detail::DeadbandWidths deadband_widths(const MapInputs& in, ErrorMap& m, const FitOptions& o,
                                       const std::vector<FunctionColumns>& fc) {
  // The ballbar's lost motion is a deadband of the backlash' width: a first fit with ideal steps gives the
  // widths, the fit itself is made with them.
  detail::DeadbandWidths deadbands;
  if (!in.ballbar_runs.empty()) {
    Blocks first = make_blocks(in, m, o);
    VectorXd t0 = VectorXd::Zero(ix(first.columns()));
    auto y0 = pseudo_readings(first, m, t0);
    Solution s0;
    for (int it = 0; it < 2; ++it) {
      s0 = solve(first, y0, selected_columns(first, fc, m));
      update_scales(first, s0);
      y0 = pseudo_readings(first, m, s0.theta);
    }
    for (std::size_t g = 0; g < first.groups.size(); ++g) {
      std::vector<double> nu(first.groups[g]->nuisance());
      for (std::size_t k = 0; k < nu.size(); ++k) nu[k] = s0.theta[ix(first.first_nuisance[g] + k)];
      if (const auto w = detail::backlash_of(*first.groups[g], nu.data()))
        deadbands[first.groups[g]->plane] = {std::max(0.0, (*w)[0]), std::max(0.0, (*w)[1])};
    }
  }
  return deadbands;
}

// The fit itself: the groups' normal equations, the linearisation iterated with each test's noise estimated
// from its residuals, the orders chosen, the final solution.
struct Fitted {
  Blocks b;
  std::vector<VectorXd> y;
  Solution s;
  std::vector<long> where;  // position of each global column in s.cols (-1: not fitted)
};

Fitted fit_core(const MapInputs& in, ErrorMap& m, const FitOptions& o, std::vector<FunctionColumns>& fc,
                const detail::DeadbandWidths& deadbands) {
  Fitted r{make_blocks(in, m, o, deadbands), {}, {}, {}};
  Blocks& b = r.b;
  for (std::size_t g = 0; g < b.groups.size(); ++g)
    for (auto& f : fc) {
      const Group& gr = *b.groups[g];
      const bool sees = gr.axis == f.axis && (gr.kind != GroupKind::traverse || f.component >= 3) &&
                        (gr.kind != GroupKind::artifact_displacement || f.component < 3) &&
                        (gr.kind != GroupKind::artifact_angles || f.component >= 3) &&
                        (gr.kind != GroupKind::artifact_roll_again || f.component == 3 + f.axis);
      if (sees && gr.in_fit) f.bic_n += static_cast<double>(gr.rows());
    }

  // Max orders first: the linearisation iterated with the exact chain, each test's noise from its residuals.
  VectorXd theta = VectorXd::Zero(ix(b.columns()));
  std::vector<VectorXd>& y = r.y;
  y = pseudo_readings(b, m, theta);
  Solution& s = r.s;
  for (int it = 0; it < std::max(2, o.gauss_newton_iterations); ++it) {
    s = solve(b, y, selected_columns(b, fc, m));
    update_scales(b, s);
    theta = s.theta;
    y = pseudo_readings(b, m, theta);
  }
  // Orders by BIC, one function at a time (chi2 with the estimated scales + k ln n).
  {
    const Normal nm = normal_of(b, y);
    for (int sweep = 0; sweep < 4; ++sweep) {
      bool changed = false;
      for (auto& f : fc) {
        const int before = f.chosen;
        int best = f.chosen;
        double best_bic = std::numeric_limits<double>::infinity();
        for (int k = f.lowest; k <= f.highest; ++k) {
          f.chosen = k;
          const double bic =
              chi2_on(nm, selected_columns(b, fc, m)) + static_cast<double>(k - f.lowest + 1) * std::log(f.bic_n);
          if (bic < best_bic - 1e-9) {
            best_bic = bic;
            best = k;
          }
        }
        f.chosen = best;
        changed = changed || best != before;
      }
      if (!changed) break;
    }
    // One order beyond BIC's choice where the data allow it: a selected order that leaves out a small true
    // term leaves its bias outside the uncertainty (on simulated days the errors then exceeded 2 u in a
    // quarter of the functions; with the margin as often as the uncertainty says: docs/map.md "Orders").
    for (auto& f : fc) f.chosen = std::min(f.highest, f.chosen + o.margin_orders);
  }
  for (int it = 0; it < std::max(2, o.gauss_newton_iterations); ++it) {
    s = solve(b, y, selected_columns(b, fc, m));
    update_scales(b, s);
    theta = s.theta;
    y = pseudo_readings(b, m, theta);
  }
  s = solve(b, y, selected_columns(b, fc, m));

  r.where.assign(b.columns(), -1);
  for (std::size_t k = 0; k < s.cols.size(); ++k) r.where[s.cols[k]] = static_cast<long>(k);
  return r;
}

// The map with the chosen orders, its coefficients and their covariance.
ErrorMap result_map(const ErrorMap& m, const std::vector<FunctionColumns>& fc, const Fitted& f) {
  const Solution& s = f.s;
  ErrorMap result = m;
  for (const auto& c : fc) {
    ErrorFunction& rf = result.function(c.axis, c.component);
    rf.orders.clear();
    for (int k = c.lowest; k <= c.chosen; ++k) rf.orders.push_back(k);
  }
  assign_parameters(result);
  std::vector<std::size_t> from;  // the max-order column of each of the result's parameters
  for (const auto& c : fc)
    for (int k = c.lowest; k <= c.chosen; ++k) from.push_back(c.first + static_cast<std::size_t>(k - c.lowest));
  for (const auto& q : m.squareness)
    if (q.parameter != no_parameter) from.push_back(q.parameter);
  const auto& where = f.where;
  std::vector<double> params(result.parameters);
  result.covariance.assign(result.parameters * result.parameters, 0.0);
  for (std::size_t i = 0; i < result.parameters; ++i) {
    params[i] = s.theta[ix(from[i])];
    for (std::size_t k = 0; k < result.parameters; ++k)
      result.covariance[i * result.parameters + k] = s.inverse(where[from[i]], where[from[k]]);
  }
  result.set_parameters(params);

  return result;
}

std::vector<GroupSummary> summaries(const Fitted& f) {
  const Blocks& b = f.b;
  const Solution& s = f.s;
  const auto& y = f.y;
  std::vector<GroupSummary> out;
  for (std::size_t g = 0; g < b.groups.size(); ++g) {
    const Group& gr = *b.groups[g];
    if (!gr.in_fit) continue;
    GroupSummary gs;
    gs.test = gr.name;
    gs.unit = gr.unit;
    gs.observations = gr.rows();
    const VectorXd r = y[g] - b.jac[g] * local_theta(b, g, s.theta);
    gs.residual_rms = std::sqrt(r.squaredNorm() / std::max<double>(1, static_cast<double>(r.size()))) * gr.unit_per_si;
    double mean_sigma2 = 0;
    for (double sg : gr.sigma) mean_sigma2 += sg * sg;
    gs.sigma = std::sqrt(b.scale2[g] * mean_sigma2 / std::max<double>(1, static_cast<double>(gr.sigma.size()))) *
               gr.unit_per_si;
    out.push_back(gs);
  }

  return out;
}

// Each axis' backlash from the ballbar planes that see it.
std::vector<AxisBacklash> axes_backlash(const Fitted& f) {
  const Blocks& b = f.b;
  const Solution& s = f.s;
  const auto& where = f.where;
  std::vector<AxisBacklash> out;
    std::array<double, 3> sw{}, swv{};
    std::array<std::string, 3> from;
    for (std::size_t g = 0; g < b.groups.size(); ++g) {
      const Group& gr = *b.groups[g];
      if (gr.kind != GroupKind::ballbar) continue;
      std::vector<double> nu(gr.nuisance());
      for (std::size_t k = 0; k < nu.size(); ++k) nu[k] = s.theta[ix(b.first_nuisance[g] + k)];
      const auto w = detail::backlash_of(gr, nu.data());
      if (!w) continue;
      const auto axes = plane_axes(gr.plane);
      for (std::size_t k = 0; k < 2; ++k) {
        std::size_t col = 0;
        for (std::size_t q = 0; q < gr.nuisance(); ++q)
          if (gr.nuisance_names[q] == gr.name + " backlash " + axis_name(axes[k])) col = b.first_nuisance[g] + q;
        const long at = where[col];
        if (at < 0) continue;
        const double var = s.inverse(at, at);
        if (!(var > 0)) continue;
        const auto a = static_cast<std::size_t>(axes[k]);
        sw[a] += 1.0 / var;
        swv[a] += (*w)[k] / var;
        from[a] += (from[a].empty() ? "" : " + ") + gr.name;
      }
    }
    for (std::size_t a = 0; a < 3; ++a)
      if (sw[a] > 0) out.push_back({static_cast<int>(a), swv[a] / sw[a], 1.0 / std::sqrt(sw[a]), from[a]});
  return out;
}

// The angles two tests give of one function (a traverse and an artifact; the artifact's two placements'
// rolls), each from its own readings.
std::vector<CrossCheck> angle_checks(const Fitted& fitted, const ErrorMap& result, const std::vector<FunctionColumns>& fc) {
  const Blocks& b = fitted.b;
  const auto& y = fitted.y;
  const Solution& s = fitted.s;
  std::vector<CrossCheck> out;
  const auto group_of = [&](GroupKind kind, int axis) -> long {
    for (std::size_t g = 0; g < b.groups.size(); ++g)
      if (b.groups[g]->kind == kind && b.groups[g]->axis == axis) return static_cast<long>(g);
    return -1;
  };
  for (const auto& f : fc) {
    if (f.component < 3) continue;
    const Role role = role_of(f.axis, f.component);
    long g1 = -1, g2 = -1;
    if (role == Role::roll) {
      g1 = group_of(GroupKind::artifact_angles, f.axis);
      g2 = group_of(GroupKind::artifact_roll_again, f.axis);
    } else {
      g1 = group_of(GroupKind::traverse, f.axis);
      g2 = group_of(GroupKind::artifact_angles, f.axis);
    }
    if (g1 < 0 || g2 < 0) continue;
    const OneSource a = from_group(b, y, s, static_cast<std::size_t>(g1), f);
    const OneSource c = from_group(b, y, s, static_cast<std::size_t>(g2), f);
    if (!a.ok || !c.ok) continue;
    out.push_back(compare_functions(result, f, a, c, b.groups[static_cast<std::size_t>(g1)]->name,
                                           b.groups[static_cast<std::size_t>(g2)]->name));
  }
  return out;
}

// A ballbar plane's local terms (the diagnostics' straightness and scale mismatch) against what the other
// tests predict for them.
std::vector<CrossCheck> ballbar_checks(const Fitted& fitted, const ErrorMap& m, const ErrorMap& result) {
  const Blocks& b = fitted.b;
  const auto& y = fitted.y;
  const Solution& s = fitted.s;
  std::vector<CrossCheck> out;
  for (std::size_t g = 0; g < b.groups.size(); ++g) {
    if (b.groups[g]->kind != GroupKind::ballbar) continue;
    const Group& gr = *b.groups[g];
    const detail::LocalModel lm = detail::local_model(gr);
    const std::size_t ng = gr.nuisance();
    // Measured: the plane's readings (less the map's part from nothing else) fitted with the local terms.
    MatrixXd x(ix(gr.rows()), lm.columns.cols() + ix(ng));
    x << lm.columns, b.jac[g].rightCols(ix(ng));
    const VectorXd w = b.w[g] / b.scale2[g];
    const MatrixXd nm = x.transpose() * w.asDiagonal() * x;
    const Eigen::FullPivLU<MatrixXd> lu(nm);
    if (!lu.isInvertible()) continue;
    const MatrixXd inv = lu.inverse();
    const MatrixXd op = inv * x.transpose() * w.asDiagonal();  // readings -> local terms
    // y[g]: the plane's readings less the chain's second-order part at the joint fit (the bar's exact length).
    const VectorXd measured = op * y[g];
    // Predicted: the map fitted without this plane, through the plane's signature.
    std::vector<bool> use(b.groups.size(), true);
    use[g] = false;
    std::vector<std::size_t> cols;
    for (std::size_t k : s.cols) {
      const bool own_nuisance = k >= b.first_nuisance[g] && k < b.first_nuisance[g] + ng;
      const bool plane_q =
          k < b.p && result.squareness[static_cast<std::size_t>(squareness_index(gr.plane))].parameter != no_parameter &&
          k == m.squareness[static_cast<std::size_t>(squareness_index(gr.plane))].parameter;
      if (!own_nuisance && !plane_q) cols.push_back(k);
    }
    const Solution wo = solve(b, y, cols, use);
    VectorXd map_theta = VectorXd::Zero(ix(b.p));
    for (std::size_t k = 0; k < b.p; ++k) map_theta[ix(k)] = wo.theta[ix(k)];
    const MatrixXd sig = b.jac[g].leftCols(ix(b.p));
    const MatrixXd gain = op * sig;  // local terms per map parameter
    const VectorXd predicted = gain * map_theta;
    // Covariance of the prediction: gain restricted to the fitted map columns.
    std::vector<std::size_t> mc;
    for (std::size_t k = 0; k < wo.cols.size(); ++k)
      if (wo.cols[k] < b.p) mc.push_back(k);
    MatrixXd gsub(gain.rows(), ix(mc.size()));
    MatrixXd csub(ix(mc.size()), ix(mc.size()));
    for (std::size_t a = 0; a < mc.size(); ++a) {
      gsub.col(ix(a)) = gain.col(ix(wo.cols[mc[a]]));
      for (std::size_t c = 0; c < mc.size(); ++c) csub(ix(a), ix(c)) = wo.inverse(ix(mc[a]), ix(mc[c]));
    }
    const MatrixXd pcov = gsub * csub * gsub.transpose();
    for (std::size_t k = 1; k < lm.names.size(); ++k) {  // not the squareness: it is this plane's own
      CrossCheck c;
      c.name = lm.names[k] + " in " + gr.plane;
      c.first = gr.name + " (its diagnostics' term)";
      c.second = "the map from the other tests";
      const std::string& nm_k = lm.names[k];
      c.unit = nm_k.substr(nm_k.rfind('_') + 1);
      const double f = lm.unit_per_si[k];
      c.value_first = measured[ix(k)] * f;
      c.u_first = std::sqrt(std::max(0.0, inv(ix(k), ix(k)))) * f;
      c.value_second = predicted[ix(k)] * f;
      c.u_second = std::sqrt(std::max(0.0, pcov(ix(k), ix(k)))) * f;
      c.difference = c.value_first - c.value_second;
      c.u_difference = std::hypot(c.u_first, c.u_second);
      c.consistent = std::abs(c.difference) <= 2.0 * c.u_difference;
      c.note = "the ballbar's term fitted to its own readings, against the same term of the readings the map "
               "without this plane predicts";
      out.push_back(c);
    }
  }
  return out;
}

// The run-out plate's squareness of the spindle against the ballbar's XZ squareness.
std::vector<CrossCheck> runout_checks(const MapInputs& in, const ErrorMap& result) {
  std::vector<CrossCheck> out;
  const auto& qxz = result.squareness[1];
  for (const auto& r : in.runouts) {
    if (!qxz.determined) continue;
    CrossCheck c;
    c.name = "squareness xz";
    c.first = "ballbar xz (the Z travel to X)";
    c.second = "run-out plate " + r.source + " (the spindle axis to X, a magnitude)";
    c.unit = "urad";
    c.value_first = std::abs(qxz.value_rad) * 1e6;
    c.u_first = std::sqrt(std::max(0.0, result.covariance_at(qxz.parameter, qxz.parameter))) * 1e6;
    c.value_second = r.squareness_rad * 1e6;
    c.u_second = r.u_rad * 1e6;
    c.difference = c.value_first - c.value_second;
    c.u_difference = std::hypot(c.u_first, c.u_second);
    c.consistent = std::abs(c.difference) <= 2.0 * c.u_difference;
    c.note = c.consistent ? "the spindle axis is parallel to the Z travel within the tests' uncertainty"
                          : "they differ: the spindle axis is not parallel to the Z travel (or a set-up differs); "
                            "the map corrects the Z travel, the run-out plate's figure is the spindle's";
    out.push_back(c);
  }
  return out;
}

}  // namespace

MapFit fit_map(const MapInputs& in, const FitOptions& o) {
  if (in.artifacts.empty() && in.traverses.empty() && in.ballbar_runs.empty())
    throw std::invalid_argument("map: no test to fit (give ballbar runs, traverses or artifacts)");
  MapFit out;
  ErrorMap m = structure(in, o);
  std::vector<FunctionColumns> fc = function_columns(m);
  const detail::DeadbandWidths deadbands = deadband_widths(in, m, o, fc);
  const Fitted fitted = fit_core(in, m, o, fc, deadbands);
  out.map = result_map(m, fc, fitted);
  out.groups = summaries(fitted);
  out.backlash = axes_backlash(fitted);
  if (o.cross_checks) {
    for (auto* checks : {&out.checks}) {
      for (auto& c : angle_checks(fitted, out.map, fc)) checks->push_back(std::move(c));
      for (auto& c : ballbar_checks(fitted, m, out.map)) checks->push_back(std::move(c));
      for (auto& c : runout_checks(in, out.map)) checks->push_back(std::move(c));
    }
  }
  // What the fit leaves out.
  for (const auto& g : fitted.b.groups)
    if (g->kind == GroupKind::ballbar && g->nuisance_names.back().find("servo") != std::string::npos)
      out.notes.push_back(g->name + ": its angles are the commanded ones: the servo lag's shift along the circle is "
                                    "not modelled (runs with angle_source = encoders, as the daemon writes, have none)");
  out.notes.push_back(
      "not modelled: a reversal spike or stick-slip on the ballbar, an autocollimator head turned about its beam, "
      "thermal drift of the axes between the tests");
  return out;
}

}  // namespace guideway::models::map
