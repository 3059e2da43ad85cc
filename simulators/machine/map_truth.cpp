// The virtual machine's 21 geometric errors as the error map defines them (map_truth.hpp), to prove a fitted map
// against.
#include "simulators/machine/map_truth.hpp"

#include <cmath>
#include <numbers>
#include <vector>

namespace guideway::simulators::machine {

namespace {

using models::map::components;
using models::map::Role;
using models::map::role_of;
using models::map::Travel;

// The function as the machine has it (no gauge), at u.
double raw(const MachineConfig& m, int j, int c, double u) {
  const AxisErrors& e = m.axis[static_cast<std::size_t>(j)];
  double v = axis_error_motions(e, j, u)[static_cast<std::size_t>(c)];
  if (c == j && e.cyclic_amplitude_m != 0 && e.cyclic_period_m > 0)
    v += e.cyclic_amplitude_m * std::sin(2.0 * std::numbers::pi * u / e.cyclic_period_m + e.cyclic_phase_rad);
  return v;
}

// Legendre coefficients 0..n of the function over the travel: (2k + 1) / 2 * integral of f P_k dxi, by
// composite Simpson on a fine grid (a lead screw's 5 mm wave over a long travel too).
std::vector<double> legendre_coefficients(const MachineConfig& m, const Travel& t, int j, int c, int n) {
  const int intervals = 4000;
  std::vector<double> out(static_cast<std::size_t>(n) + 1, 0.0), p(static_cast<std::size_t>(n) + 1);
  for (int i = 0; i <= intervals; ++i) {
    const double xi = -1.0 + 2.0 * i / intervals;
    const double w = (i == 0 || i == intervals) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    const double u = t.lo_m + 0.5 * (xi + 1.0) * t.length_m();
    models::map::legendre(xi, n, p.data());
    const double f = raw(m, j, c, u);
    for (int k = 0; k <= n; ++k) out[static_cast<std::size_t>(k)] += w * f * p[static_cast<std::size_t>(k)];
  }
  for (int k = 0; k <= n; ++k) out[static_cast<std::size_t>(k)] *= (2.0 / (3.0 * intervals)) * (2.0 * k + 1.0) / 2.0;
  return out;
}

// The squarenesses of the map's gauge: the affine field the gauge removes (the means, the straightness lines,
// the angles' means times their arms, and the machine's own squareness) has a matrix M; its symmetric part off
// the diagonal is what a rigid rotation cannot take: q_xy = M_xy + M_yx, q_xz = M_xz + M_zx, q_yz = M_yz + M_zy.
std::array<double, 3> gauge_squareness(const MachineConfig& m, const std::array<Travel, 3>& travel) {
  std::array<std::array<double, 2>, 18> removed{};  // per function: P0, P1 coefficients removed
  for (int j = 0; j < 3; ++j)
    for (int c = 0; c < components; ++c) {
      const auto co = legendre_coefficients(m, travel[static_cast<std::size_t>(j)], j, c, 1);
      removed[static_cast<std::size_t>(j * components + c)] = {co[0], role_of(j, c) == Role::straightness ? co[1] : 0.0};
    }
  const std::array<int, 3> chain{1, 0, 2};  // the machine's: bed -> Y -> X -> Z
  const auto field = [&](const Vec3& p) {
    Vec3 e{};
    for (int j = 0; j < 3; ++j) {
      const Travel& t = travel[static_cast<std::size_t>(j)];
      const double xi = t.xi(p[static_cast<std::size_t>(j)]);
      for (int c = 0; c < 3; ++c) {
        const auto& r = removed[static_cast<std::size_t>(j * components + c)];
        e[static_cast<std::size_t>(c)] += r[0] + r[1] * xi;
      }
      const Vec3 arm = models::map::rotation_arm(chain, j, p, m.tool_offset);
      const Vec3 w{removed[static_cast<std::size_t>(j * components + 3)][0],
                   removed[static_cast<std::size_t>(j * components + 4)][0],
                   removed[static_cast<std::size_t>(j * components + 5)][0]};
      e[0] += w[1] * arm[2] - w[2] * arm[1];
      e[1] += w[2] * arm[0] - w[0] * arm[2];
      e[2] += w[0] * arm[1] - w[1] * arm[0];
    }
    e[0] += m.squareness.xy * p[1] + m.squareness.xz * p[2];
    e[1] += m.squareness.yz * p[2];
    return e;
  };
  const Vec3 zero = field({0, 0, 0});
  double mm[3][3];
  for (int k = 0; k < 3; ++k) {
    Vec3 p{};
    p[static_cast<std::size_t>(k)] = 1.0;
    const Vec3 f = field(p);
    for (int i = 0; i < 3; ++i) mm[i][k] = f[static_cast<std::size_t>(i)] - zero[static_cast<std::size_t>(i)];
  }
  return {mm[0][1] + mm[1][0], mm[0][2] + mm[2][0], mm[1][2] + mm[2][1]};
}

}  // namespace

double truth_value(const MachineConfig& m, const std::array<Travel, 3>& travel, int axis, int component, double u) {
  const Travel& t = travel[static_cast<std::size_t>(axis)];
  const auto co = legendre_coefficients(m, t, axis, component, 1);
  double v = raw(m, axis, component, u) - co[0];
  if (role_of(axis, component) == Role::straightness) v -= co[1] * t.xi(u);
  return v;
}

models::map::ErrorMap truth_map(const MachineConfig& m, const std::array<Travel, 3>& travel, int max_order) {
  models::map::ErrorMap out = models::map::empty_map(travel, m.tool_offset);
  out.machine = m.name;
  for (int j = 0; j < 3; ++j)
    for (int c = 0; c < components; ++c) {
      auto& f = out.function(j, c);
      f.determined = true;
      f.determined_by = "the machine file";
      for (int k = models::map::lowest_order(j, c); k <= max_order; ++k) f.orders.push_back(k);
    }
  for (auto& q : out.squareness) {
    q.determined = true;
    q.determined_by = "the machine file";
  }
  models::map::assign_parameters(out);
  for (int j = 0; j < 3; ++j)
    for (int c = 0; c < components; ++c) {
      auto& f = out.function(j, c);
      const auto co = legendre_coefficients(m, travel[static_cast<std::size_t>(j)], j, c, max_order);
      for (std::size_t k = 0; k < f.orders.size(); ++k) f.coefficients[k] = co[static_cast<std::size_t>(f.orders[k])];
    }
  const auto q = gauge_squareness(m, travel);
  for (std::size_t i = 0; i < 3; ++i) out.squareness[i].value_rad = q[i];
  return out;
}

models::map::Vec3 static_tool_error(const Machine& machine, const Vec3& commanded, const ControllerCorrection& correction) {
  const Vec3 motor = controller_command(correction, commanded, {1, 1, 1});
  const Vec3 p = machine.static_tool_point(motor, {1, 1, 1});
  const Vec3& t = machine.config().tool_offset;
  return {p[0] - commanded[0] - t[0], p[1] - commanded[1] - t[1], p[2] - commanded[2] - t[2]};
}

}  // namespace guideway::simulators::machine
