// The virtual machine tool (machine.hpp): a 3-axis machine with geometric, servo, mechanical, thermal and noise errors.
#include "simulators/machine/machine.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Dense>

#include "simulators/machine/noise.hpp"

namespace guideway::simulators::machine {

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Vector3d v(const Vec3& a) { return {a[0], a[1], a[2]}; }
Vec3 a3(const Vector3d& x) { return {x.x(), x.y(), x.z()}; }

Matrix3d rot_x(double a) {
  Matrix3d r;
  const double c = std::cos(a), s = std::sin(a);
  r << 1, 0, 0, 0, c, -s, 0, s, c;
  return r;
}
Matrix3d rot_y(double b) {
  Matrix3d r;
  const double c = std::cos(b), s = std::sin(b);
  r << c, 0, s, 0, 1, 0, -s, 0, c;
  return r;
}
Matrix3d rot_z(double g) {
  Matrix3d r;
  const double c = std::cos(g), s = std::sin(g);
  r << c, -s, 0, s, c, 0, 0, 0, 1;
  return r;
}

// Nominal (squareness-affected) travel direction of each axis in the frame of the carriage below.
Vector3d travel_direction(const MachineConfig& m, int j) {
  switch (j) {
    case 0:
      return Vector3d::UnitX();
    case 1:
      return rot_z(-m.squareness.xy) * Vector3d::UnitY();
    default:
      return rot_y(m.squareness.xz) * rot_x(-m.squareness.yz) * Vector3d::UnitZ();
  }
}

// Rotation error motion of axis j at position u (Mu Eq. 2 order: Rx * Ry * Rz).
Matrix3d axis_rotation(const AxisErrors& e, int j, double u) {
  const auto m = axis_error_motions(e, j, u);
  return rot_x(m[3]) * rot_y(m[4]) * rot_z(m[5]);
}

// Index of the direction in which an axis' lateral play shifts it (X->y, Y->x, Z->x).
int lateral_direction(int j) { return j == 0 ? 1 : 0; }

struct Chain {
  Vector3d tool;
  Matrix3d rot[3];  // cumulative orientation of carriage Y, X, Z (indexed by Axis)
};

// Exact HTM chain bed -> Y -> X -> Z -> tool. `lateral` is the lateral-play offset of each axis.
Chain chain(const MachineConfig& m, const Vec3& u, const Vec3& lateral, double t) {
  Vector3d d[3];
  Matrix3d r[3];
  for (int j = 0; j < 3; ++j) {
    const auto& e = m.axis[static_cast<std::size_t>(j)];
    const double uj = u[static_cast<std::size_t>(j)];
    // The translations as axis_error_motions gives them, in this order of operations (recorded goldens).
    const double scale = e.scale + e.scale_drift_per_s * t;
    double along = uj * (1.0 + scale) + e.drift_m_per_s * t;
    Vector3d off = Vector3d::Zero();
    for (int i = 0; i < 3; ++i) {
      const double val = e.translation[static_cast<std::size_t>(i)](uj);
      if (i == j) {
        along += val;
      } else {
        off[i] += val;
      }
    }
    off[lateral_direction(j)] += lateral[static_cast<std::size_t>(j)];
    if (e.bump_amplitude_m != 0.0 && e.bump_direction != j && e.bump_direction >= 0 && e.bump_direction < 3) {
      const double z = (uj - e.bump_center_m) / e.bump_width_m;
      off[e.bump_direction] += e.bump_amplitude_m * std::exp(-0.5 * z * z);
    }
    d[j] = travel_direction(m, j) * along + off;
    r[j] = axis_rotation(e, j, uj);
  }
  Chain c;
  // P = dY + RY (dX + RX (dZ + RZ tool))
  c.tool = d[1] + r[1] * (d[0] + r[0] * (d[2] + r[2] * v(m.tool_offset)));
  c.rot[1] = r[1];
  c.rot[0] = r[1] * r[0];
  c.rot[2] = r[1] * r[0] * r[2];
  return c;
}

int sign_of(double x) { return x > 0 ? 1 : (x < 0 ? -1 : 0); }

constexpr double two_pi = 2.0 * std::numbers::pi;

}  // namespace

double Polynomial::operator()(double u) const noexcept {
  double acc = 0.0;
  for (auto it = c.rbegin(); it != c.rend(); ++it) acc = acc * u + *it;
  return acc;
}

double Polynomial::derivative(double u) const noexcept {
  double acc = 0.0;
  for (std::size_t k = c.size(); k-- > 1;) acc = acc * u + static_cast<double>(k) * c[k];
  return acc;
}

std::array<double, 6> axis_error_motions(const AxisErrors& e, int j, double u, double t_s) {
  std::array<double, 6> m{};
  for (std::size_t i = 0; i < 3; ++i) {
    m[i] = e.translation[i](u);
    m[3 + i] = e.rotation[i](u);
  }
  const auto J = static_cast<std::size_t>(j);
  m[J] += u * (e.scale + e.scale_drift_per_s * t_s) + e.drift_m_per_s * t_s;
  if (e.bump_amplitude_m != 0.0 && e.bump_direction != j && e.bump_direction >= 0 && e.bump_direction < 3) {
    const double z = (u - e.bump_center_m) / e.bump_width_m;
    m[static_cast<std::size_t>(e.bump_direction)] += e.bump_amplitude_m * std::exp(-0.5 * z * z);
  }
  // Periodic pitch and yaw (a rack, a lead screw): the pitch axis is y for X and Z, x for Y; the yaw axis z
  // for X and Y, x for Z (as the autocollimator traverse reads them).
  const auto wave = [u](double a, double period, double phase) {
    return a == 0.0 ? 0.0 : a * std::sin(2.0 * std::numbers::pi * u / period + phase);
  };
  m[j == 1 ? 3 : 4] += wave(e.pitch_wave_rad, e.pitch_wave_period_m, e.pitch_wave_phase_rad);
  m[j == 2 ? 3 : 5] += wave(e.yaw_wave_rad, e.yaw_wave_period_m, e.yaw_wave_phase_rad);
  if (e.bending) {
    const auto slope = [&](int i) { return std::atan(e.translation[static_cast<std::size_t>(i)].derivative(u)); };
    if (j == 0) {
      m[5] += slope(1);
      m[4] -= slope(2);
    } else if (j == 1) {
      m[5] -= slope(0);
      m[3] += slope(2);
    } else {
      m[4] += slope(0);
      m[3] -= slope(1);
    }
  }
  return m;
}

namespace {

// A controller's table lookup: value(i) interpolated linearly between the ascending positions at[0 .. n),
// the end values outside; `value(i)` gives the table's value at line i. On the tables' arrays: a run looks up
// every table at every sub-step (simulate_motion).
template <typename Value>
double table_lookup(const double* at, std::size_t n, double x, const Value& value) {
  if (x <= at[0]) return value(0);
  if (x >= at[n - 1]) return value(n - 1);
  const auto hi = static_cast<std::size_t>(std::upper_bound(at, at + n, x) - at);
  const std::size_t lo = hi - 1;
  const double f = (x - at[lo]) / (at[hi] - at[lo]);
  return value(lo) + f * (value(hi) - value(lo));
}

}  // namespace

double JointCompensation::correction_m(double commanded_m, int direction) const noexcept {
  if (nominal_m.empty() || forward_m.size() != nominal_m.size() || reverse_m.size() != nominal_m.size()) return 0.0;
  const double* nominal = nominal_m.data();
  const double* actual = (direction < 0 ? reverse_m : forward_m).data();
  return table_lookup(nominal, nominal_m.size(), commanded_m,
                      [nominal, actual](std::size_t i) { return nominal[i] - actual[i]; });
}

double CrossCompensation::at(double moving_commanded_m) const noexcept {
  if (nominal_m.empty() || correction_m.size() != nominal_m.size()) return 0.0;
  const double* correction = correction_m.data();
  return table_lookup(nominal_m.data(), nominal_m.size(), moving_commanded_m,
                      [correction](std::size_t i) { return correction[i]; });
}

// Called at every sub-step of a run (simulate_motion): on plain arrays, the same operations in the same order.
Vec3 controller_command(const ControllerCorrection& ctl, const Vec3& commanded, const std::array<int, 3>& direction) {
  double c[3] = {commanded[0], commanded[1], commanded[2]};
  if (ctl.volumetric) {
    const Vec3 v = ctl.volumetric(commanded);
    for (std::size_t j = 0; j < 3; ++j) c[j] += v[j];
  }
  double m[3] = {c[0], c[1], c[2]};
  m[0] -= ctl.skew.xy * c[1] + ctl.skew.xz * c[2];
  m[1] -= ctl.skew.yz * c[2];
  const CrossCompensation* cross = ctl.cross.data();
  for (std::size_t k = 0; k < ctl.cross.size(); ++k)
    m[static_cast<std::size_t>(cross[k].corrected)] += cross[k].at(c[static_cast<std::size_t>(cross[k].moving)]);
  const JointCompensation* tables = ctl.tables.data();
  for (std::size_t j = 0; j < 3; ++j)
    if (!tables[j].empty()) m[j] += tables[j].correction_m(m[j], direction[j]);
  return {m[0], m[1], m[2]};
}

Machine::Machine(MachineConfig config) : config_(std::move(config)) {}

Vec3 Machine::tool_point(const Vec3& axis_position, double t_s) const {
  return a3(chain(config_, axis_position, Vec3{}, t_s).tool);
}

std::array<double, 9> Machine::carriage_rotation(Axis axis, const Vec3& axis_position) const {
  const Matrix3d r = chain(config_, axis_position, Vec3{}, 0.0).rot[static_cast<int>(axis)];
  std::array<double, 9> out{};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) out[static_cast<std::size_t>(3 * i + k)] = r(i, k);
  return out;
}

MotionStepper::MotionStepper(const Machine& machine, const Vec3& motor_m, double t0_s, std::uint64_t seed)
    : machine_(&machine),
      rng_(seed != 0 ? seed : machine.config().noise.seed),
      t0_s_(t0_s),
      motor_(motor_m),
      servo_(motor_m),
      backlash_(motor_m) {}

void MotionStepper::step(const Vec3& motor_m, double t_rel_s, double dt_s) {
  const MachineConfig& config = machine_->config();
  for (std::size_t j = 0; j < 3; ++j) {
    const auto& e = config.axis[j];
    double& servo = servo_[j];
    double& lash = backlash_[j];
    const double target = motor_m[j], from = motor_[j];
    const double before = servo;
    if (e.servo_lag_s > 0) {
      // Exact response of a first-order lag to a ramp input over the step.
      const double tau = e.servo_lag_s;
      const double m = (target - from) / dt_s;
      servo = target - tau * m + (servo - from + tau * m) * std::exp(-dt_s / tau);
    } else {
      servo = target;
    }
    const double half = 0.5 * e.backlash_m;
    if (servo - lash > half) lash = servo - half;
    if (servo - lash < -half) lash = servo + half;
    const double moved = servo - before;
    const int sgn = std::abs(moved) > 1e-13 ? sign_of(moved) : 0;
    if (sgn != 0 && sgn != dir_[j]) {
      if (dir_[j] != 0) {
        t_rev_[j] = t_rel_s;
        spike_sign_[j] = sgn;
      }
      dir_[j] = sgn;
    }
  }
  motor_ = motor_m;
}

MotionSample MotionStepper::sample(const Vec3& commanded_m, double t_rel_s) {
  const MachineConfig& config = machine_->config();
  MotionSample s;
  const double t = t0_s_ + t_rel_s;
  s.t_s = t;
  s.commanded = commanded_m;
  Vec3 lateral{};
  for (std::size_t j = 0; j < 3; ++j) {
    const auto& e = config.axis[j];
    double enc = servo_[j];
    if (e.encoder_noise_m > 0) enc += e.encoder_noise_m * rng_.normal();
    if (e.encoder_resolution_m > 0) enc = std::round(enc / e.encoder_resolution_m) * e.encoder_resolution_m;
    s.encoder[j] = enc;
    double act = backlash_[j];
    if (e.cyclic_amplitude_m != 0 && e.cyclic_period_m > 0)
      act += e.cyclic_amplitude_m * std::sin(two_pi * servo_[j] / e.cyclic_period_m + e.cyclic_phase_rad);
    if (e.reversal_spike_m != 0 && spike_sign_[j] != 0 && e.reversal_spike_decay_s > 0)
      act -= spike_sign_[j] * e.reversal_spike_m * std::exp(-(t_rel_s - t_rev_[j]) / e.reversal_spike_decay_s);
    if (e.stick_slip_m != 0 && spike_sign_[j] != 0 && e.stick_slip_decay_s > 0) {
      const double since = t_rel_s - t_rev_[j];
      act -= spike_sign_[j] * e.stick_slip_m * std::exp(-since / e.stick_slip_decay_s) *
             std::sin(two_pi * e.stick_slip_hz * since);
    }
    if (e.vibration_amplitude_m != 0) act += e.vibration_amplitude_m * std::sin(two_pi * e.vibration_frequency_hz * t);
    s.axis_actual[j] = act;
    lateral[j] = 0.5 * e.lateral_play_m * dir_[j];
  }
  Vector3d tool = chain(config, s.axis_actual, lateral, t).tool;
  if (config.noise.position_m > 0)
    for (int i = 0; i < 3; ++i) tool[i] += config.noise.position_m * rng_.normal();
  s.tool = a3(tool);
  return s;
}

std::vector<MotionSample> Machine::simulate_motion(const MotionSpec& spec) const {
  std::vector<MotionSample> out;
  if (!spec.path || !(spec.duration_s >= 0.0) || !(spec.sample_rate_hz > 0.0)) return out;
  const double dt_out = 1.0 / spec.sample_rate_hz;
  const int sub = std::max(1, static_cast<int>(std::ceil(dt_out / 2e-4)));
  const double dt = dt_out / sub;
  const auto n_out = static_cast<std::size_t>(std::floor(spec.duration_s * spec.sample_rate_hz + 1e-9)) + 1;
  out.reserve(n_out);

  Vec3 cmd = spec.path(0.0);
  // The controller's compensation: the motor command is the commanded position plus the table's trim
  // for the direction of the commanded velocity (the first move's direction at the start).
  int comp_dir[3] = {1, 1, 1};
  {
    const Vec3 first = spec.path(dt);
    for (std::size_t j = 0; j < 3; ++j)
      if (first[j] < cmd[j]) comp_dir[j] = -1;
  }
  const auto& ctl = config_.controller;
  const auto motor_command = [&](const Vec3& c) {
    return controller_command(ctl, c, {comp_dir[0], comp_dir[1], comp_dir[2]});
  };
  MotionStepper machine(*this, motor_command(cmd), spec.t0_s, spec.seed);
  out.push_back(machine.sample(cmd, 0.0));
  for (std::size_t k = 1; k < n_out; ++k) {
    for (int q = 1; q <= sub; ++q) {
      const double t_rel = (static_cast<double>(k - 1) * sub + q) * dt;
      const Vec3 next = spec.path(t_rel);
      for (std::size_t j = 0; j < 3; ++j) {
        const double step = next[j] - cmd[j];
        if (std::abs(step) > 1e-13) comp_dir[j] = step > 0 ? 1 : -1;
      }
      machine.step(motor_command(next), t_rel, dt);
      cmd = next;
    }
    out.push_back(machine.sample(cmd, static_cast<double>(k) * dt_out));
  }
  return out;
}

namespace {

std::array<int, 2> plane_axes(Plane p) {
  switch (p) {
    case Plane::xy:
      return {0, 1};
    case Plane::xz:
      return {0, 2};
    default:
      return {1, 2};
  }
}

}  // namespace

Vec3 dbb_fixed_ball(const MachineConfig& config, const Vec3& center_m, Plane plane, double height_m) {
  const auto [a, b] = plane_axes(plane);
  Vector3d e1 = Vector3d::Zero(), e2 = Vector3d::Zero();
  e1[a] = 1;
  e2[b] = 1;
  // The circle is the tool point's (the commanded centre plus the tool offset); the fixed ball sits below it.
  // Only the in-plane components of the centre offset move the fixed ball sideways; an offset along
  // the normal changes the height and is applied as well (exact geometry).
  return a3(v(center_m) + v(config.tool_offset) - v(config.dbb.center_offset) - height_m * e1.cross(e2));
}

DbbBar::DbbBar(const MachineConfig& config, const Vec3& fixed_ball_m, double nominal_length_m, std::uint64_t seed)
    : errors_(config.dbb),
      fixed_(fixed_ball_m),
      nominal_m_(nominal_length_m),
      rng_((seed != 0 ? seed : config.noise.seed) ^ 0x9e3779b97f4a7c15ULL) {}

double DbbBar::read(const Vec3& tool_m, double t_s) {
  double len = (v(tool_m) - v(fixed_)).norm();
  const auto& bar = errors_;
  const double change = len - nominal_m_;
  len += bar.nonlinearity_quadratic_per_m * change * change + bar.nonlinearity_cubic_per_m2 * change * change * change;
  len += bar.bar_length_error_m + bar.bar_drift_m_per_s * t_s;
  if (bar.slip_m != 0 && t_s >= bar.slip_time_s) len += bar.slip_m;
  if (bar.noise_m > 0) len += bar.noise_m * rng_.normal();
  return len;
}

DbbRun Machine::dbb_circle(const DbbCircleSpec& spec) const {
  DbbRun run;
  run.spec = spec;
  const double r = spec.radius_m;
  const double h = spec.height_m;
  run.nominal_length_m = std::sqrt(r * r + h * h);
  if (!(r > 0) || !(spec.feed_m_per_s > 0) || !(spec.overshoot_rad >= 0) || !(spec.data_arc_rad > 0)) return run;
  const auto [a, b] = plane_axes(spec.plane);
  Vector3d e1 = Vector3d::Zero(), e2 = Vector3d::Zero();
  e1[a] = 1;
  e2[b] = 1;
  const double omega = spec.feed_m_per_s / r;
  const double sweep = spec.data_arc_rad + 2.0 * spec.overshoot_rad;
  const double duration = sweep / omega;
  const double sgn = spec.direction == formats::DbbDirection::ccw ? 1.0 : -1.0;
  const double zeta0 = spec.start_angle_rad - sgn * spec.overshoot_rad;
  const Vector3d center = v(spec.center);
  const double rate = spec.sample_rate_hz > 0 ? spec.sample_rate_hz : omega * 180.0 / std::numbers::pi * 10.0;

  MotionSpec ms;
  // Called at every sub-step of the run (simulate_motion): in scalars, the same operations as
  // center + r * (cos(z) e1 + sin(z) e2) coefficient by coefficient.
  ms.path = [=, centre = a3(center), u = a3(e1), w = a3(e2)](double t) {
    const double z = zeta0 + sgn * omega * t;
    const double cz = std::cos(z), sz = std::sin(z);
    Vec3 p;
    for (std::size_t i = 0; i < 3; ++i) {
      const double along = cz * u[i] + sz * w[i];
      p[i] = centre[i] + r * along;
    }
    return p;
  };
  ms.duration_s = duration;
  ms.sample_rate_hz = rate;
  ms.t0_s = spec.t0_s;
  ms.seed = spec.seed != 0 ? spec.seed : config_.noise.seed;
  const auto motion = simulate_motion(ms);

  DbbBar bar(config_, dbb_fixed_ball(config_, spec.center, spec.plane, h), run.nominal_length_m, ms.seed);
  run.samples.reserve(motion.size());
  for (const auto& s : motion) {
    DbbSample d;
    d.t_s = s.t_s;
    const double t_rel = s.t_s - spec.t0_s;
    d.angle_rad = zeta0 + sgn * omega * t_rel;
    const double progressed = omega * t_rel;
    d.in_data_arc =
        progressed >= spec.overshoot_rad - 1e-12 && progressed <= spec.overshoot_rad + spec.data_arc_rad + 1e-12;
    d.tool = s.tool;
    d.encoder = s.encoder;
    d.commanded = s.commanded;
    d.bar_length_m = bar.read(s.tool, s.t_s);
    d.dL_m = d.bar_length_m - run.nominal_length_m;
    run.samples.push_back(d);
  }
  return run;
}

namespace {

// Static position of an axis approached in direction `dir`: backlash, cyclic error, no lag.
double static_actual(const AxisErrors& e, double u, int dir) {
  double act = u - 0.5 * e.backlash_m * dir;
  if (e.cyclic_amplitude_m != 0 && e.cyclic_period_m > 0)
    act += e.cyclic_amplitude_m * std::sin(two_pi * u / e.cyclic_period_m + e.cyclic_phase_rad);
  return act;
}

// The instrument's own errors on the mirror's angles. They are defined on the readings as a traverse file
// holds them (pitch read = - the rotation pitch_rad, yaw read = + yaw_rad; docs/formats.md), so the
// rotation here takes them with those signs.
void read_through_instrument(const AutocollimatorErrors& a, int dir, double t_s, TraverseStation& st) {
  double pitch = -st.pitch_rad, yaw = st.yaw_rad;
  if (a.head_roll_rad != 0.0) {
    const double c = std::cos(a.head_roll_rad), s = std::sin(a.head_roll_rad);
    const double p0 = pitch;
    pitch = p0 * c + yaw * s;
    yaw = yaw * c - p0 * s;
  }
  pitch += a.pitch_drift_rad_per_s * t_s + a.rocking_rad * dir;
  yaw += a.yaw_drift_rad_per_s * t_s;
  st.pitch_rad = -pitch;
  st.yaw_rad = yaw;
}

}  // namespace

std::vector<TraverseStation> Machine::autocollimator_traverse(const TraverseSpec& spec) const {
  std::vector<TraverseStation> out;
  if (!(spec.step_m > 0)) return out;
  const int j = static_cast<int>(spec.axis);
  const double span = spec.end_m - spec.start_m;
  const int dir = sign_of(span);
  const auto n = static_cast<std::size_t>(std::floor(std::abs(span) / spec.step_m + 1e-9)) + 1;
  Rng rng(spec.seed != 0 ? spec.seed : config_.noise.seed);
  for (std::size_t k = 0; k < n; ++k) {
    const double u = spec.start_m + dir * static_cast<double>(k) * spec.step_m;
    Vec3 pos = spec.other;
    pos[static_cast<std::size_t>(j)] = u;
    Vec3 act = pos;
    Vec3 lateral{};
    for (std::size_t i = 0; i < 3; ++i) {
      const int d = static_cast<int>(i) == j ? dir : 0;
      act[i] = static_actual(config_.axis[i], pos[i], d);
      lateral[i] = 0.5 * config_.axis[i].lateral_play_m * d;
    }
    const double t = spec.t0_s + static_cast<double>(k) * spec.dwell_s;
    const Chain c = chain(config_, act, lateral, t);
    const Vector3d n_mirror = c.rot[j].col(j);
    TraverseStation st;
    st.t_s = t;
    st.position_m = u;
    st.tool = a3(c.tool);
    if (j == 0) {
      st.pitch_rad = std::atan2(-n_mirror.z(), n_mirror.x());
      st.yaw_rad = std::atan2(n_mirror.y(), n_mirror.x());
    } else if (j == 1) {
      st.pitch_rad = std::atan2(n_mirror.z(), n_mirror.y());
      st.yaw_rad = std::atan2(-n_mirror.x(), n_mirror.y());
    } else {
      st.pitch_rad = std::atan2(n_mirror.x(), n_mirror.z());
      st.yaw_rad = std::atan2(-n_mirror.y(), n_mirror.z());
    }
    read_through_instrument(config_.autocollimator, dir, t, st);
    if (config_.noise.autocollimator_rad > 0) {
      st.pitch_rad += config_.noise.autocollimator_rad * rng.normal();
      st.yaw_rad += config_.noise.autocollimator_rad * rng.normal();
    }
    out.push_back(st);
  }
  return out;
}

std::vector<std::vector<TraverseStation>> Machine::autocollimator_passes(const TraverseSpec& spec, std::size_t passes,
                                                                         double turn_s) const {
  std::vector<std::vector<TraverseStation>> out;
  TraverseSpec pass = spec;
  const std::uint64_t seed = spec.seed != 0 ? spec.seed : config_.noise.seed;
  for (std::size_t k = 0; k < passes; ++k) {
    pass.seed = seed + k;
    out.push_back(autocollimator_traverse(pass));
    if (out.back().empty()) break;
    pass.t0_s = out.back().back().t_s + turn_s;
    std::swap(pass.start_m, pass.end_m);
  }
  return out;
}

namespace {

Vector3d spindle_axis(const SpindleErrors& s) { return rot_y(s.tilt_x_rad) * rot_x(-s.tilt_y_rad) * Vector3d::UnitZ(); }
Matrix3d spindle_frame(const SpindleErrors& s) { return rot_y(s.tilt_x_rad) * rot_x(-s.tilt_y_rad); }

}  // namespace

namespace {

// A standard normal drawn from (seed, k) alone (splitmix64, Box-Muller), so reading k of an endless
// record is the same whether it is computed alone or in a run.
double normal_at(std::uint64_t seed, std::uint64_t k) {
  const auto mix = [](std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  };
  const std::uint64_t a = mix(seed ^ mix(2 * k)), b = mix(seed ^ mix(2 * k + 1));
  const double u1 = (static_cast<double>(a >> 11) + 0.5) * (1.0 / 9007199254740992.0);
  const double u2 = (static_cast<double>(b >> 11) + 0.5) * (1.0 / 9007199254740992.0);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(two_pi * u2);
}

}  // namespace

RunoutSample Machine::runout_sample(const RunoutSpec& spec, std::uint64_t k) const {
  const auto& sp = config_.spindle;
  const double omega = spec.rpm / 60.0 * two_pi;
  const double t = static_cast<double>(k) * 60.0 / spec.rpm / static_cast<double>(spec.samples_per_rev);
  double slip_s = 0.5 * sp.speed_ramp_per_s * t * t;
  if (sp.speed_ripple != 0 && sp.speed_ripple_per_rev > 0) {
    const double w = two_pi * sp.speed_ripple_per_rev * spec.rpm / 60.0;
    slip_s += sp.speed_ripple * (1.0 - std::cos(w * t)) / w;
  }
  const double theta = omega * (t + slip_s);
  // Stationary plate through the origin, its normal leaning like a spindle axis would.
  const Vector3d plate_normal = rot_z(sp.plate_parallelism_direction_rad) * rot_y(sp.plate_parallelism_rad) *
                                rot_z(-sp.plate_parallelism_direction_rad) * Vector3d::UnitZ();
  const Vector3d axis = spindle_axis(sp);
  // Probe tip: on the circle of radius R perpendicular to the (leaning) spindle axis, moved along the
  // axis by the axial error motions; the reading is the exact gap to the plate along the axis.
  double axial = sp.axial_runout_m * std::cos(2.0 * theta) + sp.axial_growth_m_per_s * t;
  for (const auto* lines : {&sp.synchronous, &sp.asynchronous})
    for (const auto& l : *lines) axial += l.amplitude_m * std::cos(l.order * theta + l.phase_rad);
  const Vector3d tip = spindle_frame(sp) * rot_z(theta) * Vector3d(spec.probe_radius_m, 0.0, 0.0) + axis * axial;
  double z = -plate_normal.dot(tip) / plate_normal.dot(axis);
  for (const auto& l : sp.plate_form)
    z += l.amplitude_m * std::cos(l.order * (theta - spec.artifact_turned_rad) + l.phase_rad);
  if (config_.noise.micrometer_m > 0)
    z += config_.noise.micrometer_m * normal_at(spec.seed != 0 ? spec.seed : config_.noise.seed, k);
  RunoutSample s;
  s.t_s = spec.t0_s + t;
  s.angle_rad = theta;
  s.displacement_m = z;
  return s;
}

std::vector<RunoutSample> Machine::runout_revolution(const RunoutSpec& spec) const {
  std::vector<RunoutSample> out;
  if (spec.samples_per_rev == 0 || !(spec.rpm > 0)) return out;
  const std::size_t n = spec.samples_per_rev * std::max<std::size_t>(1, spec.revolutions);
  out.reserve(n);
  for (std::size_t k = 0; k < n; ++k) out.push_back(runout_sample(spec, k));
  return out;
}

std::vector<ProfilePoint> Machine::facing_profile(const FacingSpec& spec) const {
  std::vector<ProfilePoint> out;
  if (!(spec.feed_m_per_s > 0) || !(spec.spindle_rpm > 0) || !(spec.profile_step_m > 0)) return out;
  const double span = spec.x_end_m - spec.x_start_m;
  const int dir = sign_of(span);
  if (dir == 0) return out;
  const auto& sp = config_.spindle;
  const Vector3d axis = spindle_axis(sp);
  const double feed_per_rev = spec.feed_m_per_s / (spec.spindle_rpm / 60.0);
  const double nose = spec.tool_nose_radius_m;
  Rng rng(spec.seed != 0 ? spec.seed : config_.noise.seed);
  const auto& ez = config_.axis[2];
  const auto n = static_cast<std::size_t>(std::floor(std::abs(span) / spec.profile_step_m + 1e-9)) + 1;
  for (std::size_t k = 0; k < n; ++k) {
    const double rho = spec.x_start_m + dir * static_cast<double>(k) * spec.profile_step_m;
    // Find the commanded x at which the actual tool point is at radius rho (two fixed-point steps).
    double x_cmd = rho;
    Vector3d p;
    double t = spec.t0_s;
    for (int it = 0; it < 3; ++it) {
      t = spec.t0_s + std::abs(x_cmd - spec.x_start_m) / spec.feed_m_per_s;
      Vec3 act{static_actual(config_.axis[0], x_cmd, dir), 0.0, static_actual(ez, spec.z_m, 0)};
      if (ez.vibration_amplitude_m != 0)
        act[2] += ez.vibration_amplitude_m * std::sin(two_pi * ez.vibration_frequency_hz * t);
      Vec3 lateral{0.5 * config_.axis[0].lateral_play_m * dir, 0.0, 0.0};
      p = chain(config_, act, lateral, t).tool;
      const double radial = (p - axis * axis.dot(p)).norm();
      x_cmd += dir * (std::abs(rho) - radial) * (rho >= 0 ? 1.0 : -1.0);
    }
    double z = axis.dot(p);
    if (spec.runout_along_path && sp.axial_runout_m != 0.0)
      z += sp.axial_runout_m * std::cos(2.0 * two_pi * spec.spindle_rpm / 60.0 * t);
    if (nose > 0 && feed_per_rev > 0) {
      const double phase = std::fmod(std::abs(rho - spec.x_start_m), feed_per_rev);
      const double d = std::min(phase, feed_per_rev - phase);
      const double dd = std::min(d, nose);
      z += nose - std::sqrt(nose * nose - dd * dd);
    }
    if (config_.noise.profilometer_m > 0) z += config_.noise.profilometer_m * rng.normal();
    out.push_back({rho, z, t});
  }
  return out;
}

std::vector<ArtifactTarget> Machine::artifact_measurement(const ArtifactSpec& spec) const {
  std::vector<ArtifactTarget> out;
  const auto j = static_cast<std::size_t>(spec.axis);
  Rng rng(spec.seed != 0 ? spec.seed : config_.noise.seed);
  for (std::size_t k = 0; k < spec.targets; ++k) {
    Vec3 pos = spec.other;
    pos[j] = spec.start_m + static_cast<double>(k) * spec.pitch_m;
    Vec3 act = pos;
    Vec3 lateral{};
    for (std::size_t i = 0; i < 3; ++i) {
      const int d = i == j ? 1 : 0;
      act[i] = static_actual(config_.axis[i], pos[i], d);
      lateral[i] = 0.5 * config_.axis[i].lateral_play_m * d;
    }
    const Chain c = chain(config_, act, lateral, spec.t0_s);
    ArtifactTarget tgt;
    tgt.nominal_m = pos[j];
    const Vector3d nominal = v(pos) + v(config_.tool_offset);
    tgt.displacement_m = a3(c.tool - nominal);
    const Matrix3d& r = c.rot[j];
    // R = Rx(a) Ry(b) Rz(c)
    tgt.rotation_rad = {std::atan2(-r(1, 2), r(2, 2)), std::asin(std::clamp(r(0, 2), -1.0, 1.0)),
                        std::atan2(-r(0, 1), r(0, 0))};
    for (std::size_t i = 0; i < 3; ++i) {
      if (config_.noise.position_m > 0) tgt.displacement_m[i] += config_.noise.position_m * rng.normal();
      if (config_.noise.autocollimator_rad > 0) tgt.rotation_rad[i] += config_.noise.autocollimator_rad * rng.normal();
    }
    out.push_back(tgt);
  }
  return out;
}

Vec3 Machine::static_tool_point(const Vec3& motor, const std::array<int, 3>& approach, double t_s) const {
  Vec3 act{};
  for (std::size_t i = 0; i < 3; ++i) act[i] = static_actual(config_.axis[i], motor[i], approach[i]);
  return a3(chain(config_, act, Vec3{}, t_s).tool);
}

CommandedPath linear_move(const Vec3& from, const Vec3& to, double feed_m_per_s) {
  const Vector3d a = v(from), b = v(to);
  const double len = (b - a).norm();
  const double dur = feed_m_per_s > 0 ? len / feed_m_per_s : 0.0;
  return [a, b, dur](double t) {
    if (dur <= 0 || t >= dur) return a3(b);
    if (t <= 0) return a3(a);
    return a3(a + (b - a) * (t / dur));
  };
}

}  // namespace guideway::simulators::machine
