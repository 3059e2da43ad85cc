// What the day's tests can see (fit_coverage.hpp): the map to fill, and why a function or squareness is not in it.
#include "models/map/fit_coverage.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "models/map/fit_groups.hpp"

namespace guideway::models::map::detail {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

Eigen::Index ix(std::size_t i) { return static_cast<Eigen::Index>(i); }

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

// Why a function no test of the day saw is not in the map, and what would determine it.
std::string why_not(int j, int c) {
  const std::string a = axis_upper(j);
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
    if (traverse) by.push_back("traverse " + axis_upper(j));
  }
  if (cv.artifact[J]) by.push_back("artifact " + axis_upper(j));
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
  const auto groups = make_groups(only, probe, std::min<std::size_t>(o.ballbar_samples_per_run, 360));
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

}  // namespace

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
        f.why = "the tests along " + axis_upper(j) + " read too few positions (" + std::to_string(n_pos) +
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

}  // namespace guideway::models::map::detail
