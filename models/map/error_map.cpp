// The error map of a three-axis machine (error_map.hpp): ISO 230-1's 21 geometric errors as one model through the
// chain.
#include "models/map/error_map.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

namespace guideway::models::map {

namespace {

using Eigen::Vector3d;


Vector3d v3(const Vec3& a) { return {a[0], a[1], a[2]}; }
Vec3 a3(const Vector3d& x) { return {x.x(), x.y(), x.z()}; }

double squareness_of(const ErrorMap& m, int i) { return m.squareness[static_cast<std::size_t>(i)].value_rad; }

// Position in the chain of each axis (0 = on the bed).
std::array<int, 3> level_of(const ErrorMap& m) {
  std::array<int, 3> level{};
  for (int k = 0; k < 3; ++k) level[static_cast<std::size_t>(m.chain[static_cast<std::size_t>(k)])] = k;
  return level;
}

void check_chain(const ErrorMap& m) {
  std::array<int, 3> seen{};
  for (int a : m.chain) {
    if (a < 0 || a > 2 || seen[static_cast<std::size_t>(a)]++ != 0)
      throw std::invalid_argument("error map: the chain must name each axis once");
  }
}

}  // namespace

std::string axis_name(int axis) { return std::string(1, "xyz"[axis]); }

std::string function_name(int axis, int component) {
  return std::string("E") + "XYZABC"[component] + "XYZ"[axis];
}

int pitch_component(int axis) { return axis == 1 ? 3 : 4; }
int yaw_component(int axis) { return axis == 2 ? 3 : 5; }

Role role_of(int axis, int component) {
  if (component < 3) return component == axis ? Role::positioning : Role::straightness;
  if (component - 3 == axis) return Role::roll;
  return component == pitch_component(axis) ? Role::pitch : Role::yaw;
}

std::string role_name(Role role) {
  switch (role) {
    case Role::positioning:
      return "positioning";
    case Role::straightness:
      return "straightness";
    case Role::roll:
      return "roll";
    case Role::pitch:
      return "pitch";
    case Role::yaw:
      return "yaw";
  }
  return "?";
}

int lowest_order(int axis, int component) { return role_of(axis, component) == Role::straightness ? 2 : 1; }

void legendre(double xi, int n, double* p, double* dp) {
  p[0] = 1.0;
  if (dp) dp[0] = 0.0;
  if (n >= 1) {
    p[1] = xi;
    if (dp) dp[1] = 1.0;
  }
  for (int k = 1; k < n; ++k) {
    p[k + 1] = ((2.0 * k + 1.0) * xi * p[k] - k * p[k - 1]) / (k + 1.0);
    if (dp) dp[k + 1] = dp[k - 1] + (2.0 * k + 1.0) * p[k];
  }
}

FunctionFigures function_figures(const ErrorMap& m, int axis, int component, int points) {
  FunctionFigures f;
  const Travel& t = m.travel[static_cast<std::size_t>(axis)];
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, s2 = 0, u2 = 0;
  for (int i = 0; i < points; ++i) {
    const double u = t.lo_m + t.length_m() * i / std::max(1, points - 1);
    const double v = m.value(axis, component, u);
    const double uu = m.uncertainty(axis, component, u);
    lo = std::min(lo, v);
    hi = std::max(hi, v);
    s2 += v * v;
    u2 += uu * uu;
  }
  f.rms = std::sqrt(s2 / points);
  f.peak_to_valley = hi - lo;
  f.u_rms = std::sqrt(u2 / points);
  return f;
}

int squareness_index(const std::string& plane) {
  if (plane == "xy") return 0;
  if (plane == "xz") return 1;
  if (plane == "yz") return 2;
  return -1;
}

double ErrorMap::value(int axis, int component, double u_m) const {
  const ErrorFunction& f = function(axis, component);
  if (!f.determined || f.coefficients.empty()) return 0.0;
  const int n = f.orders.back();
  std::vector<double> p(static_cast<std::size_t>(n) + 1);
  legendre(travel[static_cast<std::size_t>(axis)].xi(u_m), n, p.data());
  double s = 0.0;
  for (std::size_t k = 0; k < f.orders.size(); ++k) s += f.coefficients[k] * p[static_cast<std::size_t>(f.orders[k])];
  return s;
}

double ErrorMap::uncertainty(int axis, int component, double u_m) const {
  const ErrorFunction& f = function(axis, component);
  if (!f.determined || f.coefficients.empty()) return std::numeric_limits<double>::quiet_NaN();
  if (covariance.empty() || f.first_parameter == no_parameter) return 0.0;
  const int n = f.orders.back();
  std::vector<double> p(static_cast<std::size_t>(n) + 1);
  legendre(travel[static_cast<std::size_t>(axis)].xi(u_m), n, p.data());
  double var = 0.0;
  for (std::size_t a = 0; a < f.orders.size(); ++a)
    for (std::size_t b = 0; b < f.orders.size(); ++b)
      var += p[static_cast<std::size_t>(f.orders[a])] * p[static_cast<std::size_t>(f.orders[b])] *
             covariance_at(f.first_parameter + a, f.first_parameter + b);
  return std::sqrt(std::max(var, 0.0));
}

std::vector<double> ErrorMap::parameter_vector() const {
  std::vector<double> p(parameters, 0.0);
  for (const auto& axis : functions)
    for (const auto& f : axis)
      if (f.first_parameter != no_parameter)
        for (std::size_t k = 0; k < f.coefficients.size(); ++k) p[f.first_parameter + k] = f.coefficients[k];
  for (const auto& q : squareness)
    if (q.parameter != no_parameter) p[q.parameter] = q.value_rad;
  return p;
}

void ErrorMap::set_parameters(const std::vector<double>& p) {
  if (p.size() != parameters) throw std::invalid_argument("error map: parameter vector of the wrong length");
  for (auto& axis : functions)
    for (auto& f : axis)
      if (f.first_parameter != no_parameter)
        for (std::size_t k = 0; k < f.coefficients.size(); ++k) f.coefficients[k] = p[f.first_parameter + k];
  for (auto& q : squareness)
    if (q.parameter != no_parameter) q.value_rad = p[q.parameter];
}

ErrorMap empty_map(const std::array<Travel, 3>& travel, const Vec3& tool_offset_m) {
  ErrorMap m;
  m.travel = travel;
  m.tool_offset_m = tool_offset_m;
  for (int j = 0; j < 3; ++j)
    for (int c = 0; c < components; ++c) {
      ErrorFunction& f = m.function(j, c);
      f.axis = j;
      f.component = c;
    }
  const char* planes[] = {"xy", "xz", "yz"};
  for (std::size_t i = 0; i < 3; ++i) m.squareness[i].plane = planes[i];
  return m;
}

void assign_parameters(ErrorMap& m) {
  std::size_t next = 0;
  for (auto& axis : m.functions)
    for (auto& f : axis) {
      f.first_parameter = no_parameter;
      if (!f.determined || f.orders.empty()) {
        f.coefficients.clear();
        continue;
      }
      f.coefficients.assign(f.orders.size(), 0.0);
      f.first_parameter = next;
      next += f.orders.size();
    }
  for (auto& q : m.squareness) {
    q.parameter = q.determined ? next++ : no_parameter;
    if (!q.determined) q.value_rad = 0.0;
  }
  m.parameters = next;
  m.covariance.clear();
}

Vec3 rotation_arm(const std::array<int, 3>& chain, int axis, const Vec3& position, const Vec3& tool_offset) {
  std::array<int, 3> level{};
  for (int k = 0; k < 3; ++k) level[static_cast<std::size_t>(chain[static_cast<std::size_t>(k)])] = k;
  Vec3 arm = tool_offset;
  for (std::size_t i = 0; i < 3; ++i)
    if (level[i] > level[static_cast<std::size_t>(axis)]) arm[i] += position[i];
  return arm;
}

Vec3 tool_error(const ErrorMap& m, const Vec3& position, const Vec3& tool_offset) {
  check_chain(m);
  Vector3d e = Vector3d::Zero();
  for (int j = 0; j < 3; ++j) {
    const double u = position[static_cast<std::size_t>(j)];
    const Vector3d arm = v3(rotation_arm(m.chain, j, position, tool_offset));
    const Vector3d d(m.value(j, 0, u), m.value(j, 1, u), m.value(j, 2, u));
    const Vector3d w(m.value(j, 3, u), m.value(j, 4, u), m.value(j, 5, u));
    e += d + w.cross(arm);
  }
  e[0] += squareness_of(m, 0) * position[1] + squareness_of(m, 1) * position[2];
  e[1] += squareness_of(m, 2) * position[2];
  return a3(e);
}

Vec3 carriage_angles(const ErrorMap& m, int axis, const Vec3& position) {
  check_chain(m);
  const auto level = level_of(m);
  Vec3 a{};
  for (int j = 0; j < 3; ++j) {
    if (level[static_cast<std::size_t>(j)] > level[static_cast<std::size_t>(axis)]) continue;
    for (int r = 0; r < 3; ++r) a[static_cast<std::size_t>(r)] += m.value(j, 3 + r, position[static_cast<std::size_t>(j)]);
  }
  return a;
}

namespace {

// Basis values of function f at u (one per order) into `out`.
void basis(const ErrorMap& m, const ErrorFunction& f, double u, std::vector<double>& out) {
  const int n = f.orders.back();
  std::vector<double> p(static_cast<std::size_t>(n) + 1);
  legendre(m.travel[static_cast<std::size_t>(f.axis)].xi(u), n, p.data());
  out.resize(f.orders.size());
  for (std::size_t k = 0; k < f.orders.size(); ++k) out[k] = p[static_cast<std::size_t>(f.orders[k])];
}

}  // namespace

void tool_error_jacobian(const ErrorMap& m, const Vec3& position, const Vec3& tool_offset, double* rows) {
  check_chain(m);
  const std::size_t n = m.parameters;
  std::fill(rows, rows + 3 * n, 0.0);
  std::vector<double> phi;
  for (int j = 0; j < 3; ++j) {
    const Vector3d arm = v3(rotation_arm(m.chain, j, position, tool_offset));
    for (int c = 0; c < components; ++c) {
      const ErrorFunction& f = m.function(j, c);
      if (f.first_parameter == no_parameter) continue;
      basis(m, f, position[static_cast<std::size_t>(j)], phi);
      Vector3d dir;
      if (c < 3) {
        dir = Vector3d::Unit(c);
      } else {
        dir = Vector3d::Unit(c - 3).cross(arm);
      }
      for (std::size_t k = 0; k < phi.size(); ++k)
        for (int r = 0; r < 3; ++r) rows[static_cast<std::size_t>(r) * n + f.first_parameter + k] = dir[r] * phi[k];
    }
  }
  const auto& q = m.squareness;
  if (q[0].parameter != no_parameter) rows[0 * n + q[0].parameter] = position[1];
  if (q[1].parameter != no_parameter) rows[0 * n + q[1].parameter] = position[2];
  if (q[2].parameter != no_parameter) rows[1 * n + q[2].parameter] = position[2];
}

void carriage_angles_jacobian(const ErrorMap& m, int axis, const Vec3& position, double* rows) {
  check_chain(m);
  const std::size_t n = m.parameters;
  std::fill(rows, rows + 3 * n, 0.0);
  const auto level = level_of(m);
  std::vector<double> phi;
  for (int j = 0; j < 3; ++j) {
    if (level[static_cast<std::size_t>(j)] > level[static_cast<std::size_t>(axis)]) continue;
    for (int r = 0; r < 3; ++r) {
      const ErrorFunction& f = m.function(j, 3 + r);
      if (f.first_parameter == no_parameter) continue;
      basis(m, f, position[static_cast<std::size_t>(j)], phi);
      for (std::size_t k = 0; k < phi.size(); ++k) rows[static_cast<std::size_t>(r) * n + f.first_parameter + k] = phi[k];
    }
  }
}

}  // namespace guideway::models::map
