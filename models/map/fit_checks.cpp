// The cross-checks of the map's fit (fit_checks.hpp): where two tests determine one quantity, each from its own
// readings.
#include "models/map/fit_checks.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace guideway::models::map::detail {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

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
  c.name = role_name(role) + " of " + axis_upper(f.axis) + " (" + function_name(f.axis, f.component) + ")";
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
    const LocalModel lm = local_model(gr);
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

std::vector<CrossCheck> cross_checks(const MapInputs& in, const Fitted& fitted, const ErrorMap& m, const ErrorMap& result,
                                     const std::vector<FunctionColumns>& fc) {
  std::vector<CrossCheck> out = angle_checks(fitted, result, fc);
  for (auto& c : ballbar_checks(fitted, m, result)) out.push_back(std::move(c));
  for (auto& c : runout_checks(in, result)) out.push_back(std::move(c));
  return out;
}

}  // namespace guideway::models::map::detail
