// One model of the machine from the day's tests (fit.hpp): every test's readings fitted together through the chain,
// step by step (what the tests see: fit_coverage; the least squares: fit_solver; the cross-checks: fit_checks).
#include "models/map/fit.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "models/map/fit_checks.hpp"
#include "models/map/fit_coverage.hpp"
#include "models/map/fit_groups.hpp"
#include "models/map/fit_solver.hpp"

namespace guideway::models::map {

namespace {

using detail::Blocks;
using detail::chi2_on;
using detail::Fitted;
using detail::function_columns;
using detail::FunctionColumns;
using detail::Group;
using detail::GroupKind;
using detail::ix;
using detail::make_blocks;
using detail::Normal;
using detail::normal_of;
using detail::pseudo_readings;
using detail::selected_columns;
using detail::solve;
using detail::Solution;
using detail::update_scales;
using Eigen::VectorXd;

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

}  // namespace

MapFit fit_map(const MapInputs& in, const FitOptions& o) {
  if (in.artifacts.empty() && in.traverses.empty() && in.ballbar_runs.empty())
    throw std::invalid_argument("map: no test to fit (give ballbar runs, traverses or artifacts)");
  MapFit out;
  ErrorMap m = detail::structure(in, o);
  std::vector<FunctionColumns> fc = function_columns(m);
  const detail::DeadbandWidths deadbands = deadband_widths(in, m, o, fc);
  const Fitted fitted = fit_core(in, m, o, fc, deadbands);
  out.map = result_map(m, fc, fitted);
  out.groups = summaries(fitted);
  out.backlash = axes_backlash(fitted);
  if (o.cross_checks) out.checks = detail::cross_checks(in, fitted, m, out.map, fc);
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
