// The virtual machine tool as the CAN and serial emulators' source (can_serial_machine_sources.hpp): a DBB circle, a
// traverse.
#include "simulators/emulators/can_serial_machine_sources.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>

namespace guideway::simulators::emulators {

namespace {

// Bar length and the three axes' encoders between two samples (w: 0 at lo, 1 at hi), in bus order.
void interpolate(const machine::DbbSample& lo, const machine::DbbSample& hi, double w, machine::Plane plane,
                 std::span<double> out) {
  const auto axes = bus_axes(plane);
  const double v[4] = {lo.bar_length_m + w * (hi.bar_length_m - lo.bar_length_m),
                       lo.encoder[axes[0]] + w * (hi.encoder[axes[0]] - lo.encoder[axes[0]]),
                       lo.encoder[axes[1]] + w * (hi.encoder[axes[1]] - lo.encoder[axes[1]]),
                       lo.encoder[axes[2]] + w * (hi.encoder[axes[2]] - lo.encoder[axes[2]])};
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = i < 4 ? v[i] : 0.0;
}

constexpr double rad_to_arcsec = 180.0 * 3600.0 / 3.14159265358979323846;

}  // namespace

std::array<int, 3> bus_axes(machine::Plane plane) {
  switch (plane) {
    case machine::Plane::xy:
      return {0, 1, 2};
    case machine::Plane::xz:
      return {0, 2, 1};
    case machine::Plane::yz:
      return {1, 2, 0};
  }
  return {0, 1, 2};
}

void DbbMotion::at(double t_s, std::span<double> out) const {
  const auto& s = run.samples;
  if (s.empty()) return;
  double t = s.front().t_s + std::fmod(std::max(t_s, 0.0), duration_s > 0 ? duration_s : 1.0);
  auto hi = std::lower_bound(s.begin(), s.end(), t, [](const machine::DbbSample& a, double v) { return a.t_s < v; });
  if (hi == s.begin()) hi = s.begin() + 1;
  if (hi == s.end()) hi = s.end() - 1;
  const auto lo = hi - 1;
  const double span = hi->t_s - lo->t_s;
  const double w = span > 0 ? std::clamp((t - lo->t_s) / span, 0.0, 1.0) : 0.0;
  interpolate(*lo, *hi, w, plane, out);
}

std::shared_ptr<const DbbMotion> make_dbb_motion(const machine::Machine& machine, const machine::DbbCircleSpec& spec) {
  auto m = std::make_shared<DbbMotion>();
  m->run = machine.dbb_circle(spec);
  m->plane = spec.plane;
  if (m->run.samples.size() >= 2) m->duration_s = m->run.samples.back().t_s - m->run.samples.front().t_s;
  return m;
}

void DbbProgram::at(double t_s, std::span<double> out) const {
  double t = std::fmod(std::max(t_s, 0.0), duration_s > 0 ? duration_s : 1.0);
  for (const machine::DbbRun& run : runs) {
    if (run.samples.empty()) continue;
    const double length = run.samples.back().t_s - run.samples.front().t_s;
    if (t <= length + pause_s) {
      // Interpolation within the circle; during the pause the last sample holds.
      const auto& s = run.samples;
      const double tt = std::min(t, length);
      auto hi = std::lower_bound(s.begin(), s.end(), s.front().t_s + tt,
                                 [](const machine::DbbSample& a, double v) { return a.t_s < v; });
      if (hi == s.begin()) hi = s.begin() + 1;
      if (hi == s.end()) hi = s.end() - 1;
      const auto lo = hi - 1;
      const double span = hi->t_s - lo->t_s;
      const double w = span > 0 ? std::clamp((s.front().t_s + tt - lo->t_s) / span, 0.0, 1.0) : 0.0;
      interpolate(*lo, *hi, w, plane, out);
      return;
    }
    t -= length + pause_s;
  }
}

std::size_t DbbProgram::circle_at(double t_s, double& start_s) const {
  start_s = 0;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const auto& s = runs[k].samples;
    const double span = (s.empty() ? 0.0 : s.back().t_s - s.front().t_s) + pause_s;
    if (t_s < start_s + span || k + 1 == runs.size()) return k;
    start_s += span;
  }
  return 0;
}

std::shared_ptr<DbbProgram> make_dbb_program(const machine::Machine& machine, std::vector<machine::DbbCircleSpec> specs,
                                             double pause_s, double t0_s) {
  auto p = std::make_shared<DbbProgram>();
  p->pause_s = pause_s;
  double t0 = t0_s;
  if (!specs.empty()) p->plane = specs.front().plane;  // the bus order of the axes, whatever plane each circle is in
  for (auto& spec : specs) {
    spec.t0_s = t0;
    p->runs.push_back(machine.dbb_circle(spec));
    const auto& s = p->runs.back().samples;
    const double length = s.empty() ? 0.0 : s.back().t_s - s.front().t_s;
    t0 += length + pause_s;
  }
  p->duration_s = t0 - t0_s;
  return p;
}

DbbProgramPlayer::DbbProgramPlayer(const machine::Machine& machine, std::vector<machine::DbbCircleSpec> specs,
                                   double pause_s)
    : machine_(machine),
      specs_(std::move(specs)),
      bus_plane_(specs_.empty() ? machine::Plane::xy : specs_.front().plane),
      pause_s_(pause_s) {
  make_pass(0);
  duration_s_ = current_->duration_s;
}

void DbbProgramPlayer::make_pass(long long pass) {
  std::vector<machine::DbbCircleSpec> pass_specs = specs_;
  const std::uint64_t base = machine_.config().noise.seed;
  for (std::size_t k = 0; k < pass_specs.size(); ++k)
    pass_specs[k].seed =
        (pass_specs[k].seed != 0 ? pass_specs[k].seed : base) + static_cast<std::uint64_t>(pass) * 7919u + k;
  const double d = duration_s_ > 0 ? duration_s_ : 1.0;
  auto program = make_dbb_program(machine_, pass_specs, pause_s_, origin_s_ + static_cast<double>(pass - first_pass_) * d);
  program->plane = bus_plane_;
  current_ = std::move(program);
  pass_ = pass;
}

void DbbProgramPlayer::retarget(double feed_m_per_s, double radius_m) {
  std::lock_guard lock(mutex_);
  const bool same = std::all_of(specs_.begin(), specs_.end(), [&](const machine::DbbCircleSpec& s) {
    return s.feed_m_per_s == feed_m_per_s && (radius_m <= 0 || s.radius_m == radius_m);
  });
  if (same) {
    pending_.reset();  // an earlier request not yet played is replaced by "as now"
    return;
  }
  pending_ = Retarget{feed_m_per_s, radius_m};
}

void DbbProgramPlayer::at(double t_s, std::span<double> out) {
  std::shared_ptr<const DbbProgram> program;
  double local_s = 0;
  {
    std::lock_guard lock(mutex_);
    const double t = std::max(t_s, origin_s_);  // time runs forward: before the last retarget's start, hold it
    const double d = duration_s_ > 0 ? duration_s_ : 1.0;
    const auto pass = first_pass_ + static_cast<long long>(std::floor((t - origin_s_) / d));
    if (pass != pass_) make_pass(pass);
    local_s = t - (origin_s_ + static_cast<double>(pass - first_pass_) * d);
    if (pending_) {
      double start_s = 0;
      const std::size_t circle = current_->circle_at(local_s, start_s);
      if (!pending_->seen) {
        pending_->seen = true;
        pending_->pass = pass;
        pending_->circle = circle;
      } else if (pass != pending_->pass || circle != pending_->circle) {
        // The circle traced when the retarget came has ended, with its pause: the program goes on from this
        // circle, where that one ended, at the new feed (and radius).
        std::rotate(specs_.begin(), specs_.begin() + static_cast<std::ptrdiff_t>(circle), specs_.end());
        for (machine::DbbCircleSpec& s : specs_) {
          s.feed_m_per_s = pending_->feed_m_per_s;
          if (pending_->radius_m > 0) s.radius_m = pending_->radius_m;
        }
        origin_s_ += static_cast<double>(pass - first_pass_) * d + start_s;
        first_pass_ = pass + 1;  // a pass of its own: noise seeded apart from every pass before
        pending_.reset();
        duration_s_ = 0;
        make_pass(first_pass_);
        duration_s_ = current_->duration_s;
        local_s = t - origin_s_;
      }
    }
    program = current_;
  }
  program->at(local_s, out);
}

DbbSource DbbProgramPlayer::source(std::shared_ptr<DbbProgramPlayer> player) {
  return [player = std::move(player)](double t_s, std::span<double> out) { player->at(t_s, out); };
}

DbbSource dbb_motion_source(std::shared_ptr<const DbbMotion> motion) {
  return [motion](double t_s, std::span<double> out) { motion->at(t_s, out); };
}

double TraverseMotion::duration_s() const {
  const double n = static_cast<double>(stations.size());
  return n * dwell_s + (n - 1) * move_s + return_s;
}

namespace {

// Index of the station at time t within one pass, and whether the reflector sits on it.
std::pair<std::size_t, bool> traverse_phase(const TraverseMotion& m, double t_s) {
  const double total = m.duration_s();
  double t = std::fmod(std::max(t_s, 0.0), total > 0 ? total : 1.0);
  const double period = m.dwell_s + m.move_s;
  const auto k = std::min(static_cast<std::size_t>(t / period), m.stations.size() - 1);
  t -= static_cast<double>(k) * period;
  return {k, t < m.dwell_s};
}

}  // namespace

const machine::TraverseStation& TraverseMotion::at(double t_s) const {
  return stations[traverse_phase(*this, t_s).first];
}

bool TraverseMotion::reflecting(double t_s) const { return traverse_phase(*this, t_s).second; }

std::shared_ptr<const TraverseMotion> make_traverse_motion(const machine::Machine& machine,
                                                           const machine::TraverseSpec& spec, double move_s,
                                                           double return_s, std::size_t passes) {
  auto m = std::make_shared<TraverseMotion>();
  m->dwell_s = spec.dwell_s > 0 ? spec.dwell_s : 1.0;
  m->move_s = std::max(0.0, move_s);
  m->return_s = std::max(0.0, return_s);
  // Station k of the program is read at machine time k x (dwell + move), the time its dwell starts, so that
  // a drift in time is what the session's clock sees.
  machine::TraverseSpec timed = spec;
  timed.dwell_s = m->dwell_s + m->move_s;
  for (auto& pass : machine.autocollimator_passes(timed, std::max<std::size_t>(passes, 1), timed.dwell_s))
    m->stations.insert(m->stations.end(), pass.begin(), pass.end());
  if (m->stations.empty()) m->stations.push_back({});
  return m;
}

AutocollimatorSource traverse_source(std::shared_ptr<const TraverseMotion> motion) {
  return [motion](double t_s) {
    const auto& st = motion->at(t_s);
    return AutocollimatorView{st.yaw_rad * rad_to_arcsec, st.pitch_rad * rad_to_arcsec, motion->reflecting(t_s)};
  };
}

machine::MachineConfig demo_machine_config() {
  machine::MachineConfig c;
  c.name = "demo";
  c.squareness.xy = 20e-6;
  c.axis[0].servo_lag_s = 0.010;
  c.axis[1].servo_lag_s = 0.011;
  c.axis[0].backlash_m = 2e-6;
  c.axis[0].rotation[1].c = {0.0, 30e-6, -40e-6};  // E_BX: pitch of X, rad
  c.axis[0].rotation[2].c = {0.0, -15e-6, 25e-6};  // E_CX: yaw of X, rad
  c.dbb.noise_m = 0.1e-6;
  c.noise.autocollimator_rad = 0.05e-6;
  return c;
}

}  // namespace guideway::simulators::emulators
