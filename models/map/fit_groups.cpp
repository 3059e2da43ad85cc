// The observation groups of the map's fit (fit_groups.hpp): each test's readings with their derivatives and set-up
// terms.
#include "models/map/fit_groups.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <numeric>
#include <stdexcept>

#include <Eigen/Dense>

#include "core/units.hpp"
#include "models/dbb/geometry.hpp"

namespace guideway::models::map::detail {

namespace {

using Eigen::MatrixXd;
using Eigen::Vector3d;

Vector3d v3(const Vec3& a) { return {a[0], a[1], a[2]}; }

// The readings the test states no uncertainty for get this floor (a noise-free simulation).
constexpr double sigma_floor_m = 1e-10;
constexpr double sigma_floor_rad = 1e-10;

// ---- The artifact on one axis ----

// Its targets' positions (the other axes where the artifact lay).
std::vector<Vec3> target_positions(const ArtifactTest& t) {
  std::vector<Vec3> p;
  for (double u : t.position_m) {
    Vec3 q = t.other_m;
    q[static_cast<std::size_t>(t.axis)] = u;
    p.push_back(q);
  }
  return p;
}

double mean_of(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

// Every target is relative to target 0, so each value carries target 0's noise as well as its own: the
// set-up's constant takes the common part, and a target's own part is u / sqrt(2) (target 0's: target 1's).
double own_part(const std::vector<double>& u_of_target, std::size_t i, double floor) {
  const double u = i == 0 && u_of_target.size() > 1 ? u_of_target[1] : u_of_target[i];
  return std::max(u / std::sqrt(2.0), floor);
}

class ArtifactDisplacements : public Group {
 public:
  ArtifactDisplacements(const ArtifactTest& t, const Vec3& tool) : tool_(tool), at_(target_positions(t)) {
    kind = GroupKind::artifact_displacement;
    stated_sigma = true;
    axis = t.axis;
    test = "artifact " + axis_upper(axis);
    name = test + " displacements";
    unit = "um";
    unit_per_si = 1e6;
    mid_ = mean_of(t.position_m);
    for (std::size_t m = 0; m < 3; ++m)
      if (static_cast<int>(m) != axis) across_.push_back(m);
    for (std::size_t i = 0; i < at_.size(); ++i) {
      u_.push_back(t.position_m[i] - mid_);
      for (std::size_t m = 0; m < 3; ++m) {
        y.push_back(t.displacement_m[i][m]);
        std::vector<double> um;
        for (const auto& v : t.u_displacement_m) um.push_back(v[m]);
        sigma.push_back(own_part(um, i, sigma_floor_m));
      }
    }
    for (std::size_t m = 0; m < 3; ++m) nuisance_names.push_back(test + " offset " + axis_name(static_cast<int>(m)));
    for (std::size_t m : across_) nuisance_names.push_back(test + " alignment in " + axis_name(static_cast<int>(m)));
  }
  void jacobian(const ErrorMap& map, MatrixXd& j) const override {
    const std::size_t p = map.parameters;
    j.setZero(static_cast<Eigen::Index>(rows()), static_cast<Eigen::Index>(p + nuisance()));
    std::vector<double> rows3(3 * p);
    for (std::size_t i = 0; i < at_.size(); ++i) {
      if (p > 0) tool_error_jacobian(map, at_[i], tool_, rows3.data());
      for (std::size_t m = 0; m < 3; ++m) {
        const auto r = static_cast<Eigen::Index>(3 * i + m);
        for (std::size_t k = 0; k < p; ++k) j(r, static_cast<Eigen::Index>(k)) = rows3[m * p + k];
        j(r, static_cast<Eigen::Index>(p + m)) = 1.0;
        for (std::size_t a = 0; a < across_.size(); ++a)
          if (across_[a] == m) j(r, static_cast<Eigen::Index>(p + 3 + a)) = u_[i];
      }
    }
  }
  void predict(const ErrorMap& map, const double* nu, double* out) const override {
    for (std::size_t i = 0; i < at_.size(); ++i) {
      const Vec3 e = tool_error(map, at_[i], tool_);
      for (std::size_t m = 0; m < 3; ++m) {
        double v = e[m] + nu[m];
        for (std::size_t a = 0; a < across_.size(); ++a)
          if (across_[a] == m) v += nu[3 + a] * u_[i];
        out[3 * i + m] = v;
      }
    }
  }

 private:
  Vec3 tool_;
  std::vector<Vec3> at_;
  std::vector<double> u_;
  std::vector<std::size_t> across_;
  double mid_ = 0.0;
};

class ArtifactAngles : public Group {
 public:
  ArtifactAngles(const ArtifactTest& t, bool roll_again) : again_(roll_again), at_(target_positions(t)) {
    kind = roll_again ? GroupKind::artifact_roll_again : GroupKind::artifact_angles;
    stated_sigma = true;
    in_fit = !roll_again;
    axis = t.axis;
    test = "artifact " + axis_upper(axis);
    name = test + (roll_again ? " roll, second placement" : " angles");
    unit = "arcsec";
    unit_per_si = 1.0 / rad_per_arcsec;
    for (std::size_t i = 0; i < at_.size(); ++i) {
      if (roll_again) {
        y.push_back(t.roll_again_rad[i]);
        sigma.push_back(own_part(t.u_roll_again_rad, i, sigma_floor_rad));
        continue;
      }
      for (std::size_t r = 0; r < 3; ++r) {
        y.push_back(t.rotation_rad[i][r]);
        std::vector<double> ur;
        for (const auto& v : t.u_rotation_rad) ur.push_back(v[r]);
        sigma.push_back(own_part(ur, i, sigma_floor_rad));
      }
    }
    if (roll_again) {
      nuisance_names.push_back(name + " zero");
    } else {
      for (int r = 0; r < 3; ++r) nuisance_names.push_back(test + " zero about " + axis_name(r));
    }
  }
  void jacobian(const ErrorMap& map, MatrixXd& j) const override {
    const std::size_t p = map.parameters;
    j.setZero(static_cast<Eigen::Index>(rows()), static_cast<Eigen::Index>(p + nuisance()));
    std::vector<double> rows3(3 * p);
    for (std::size_t i = 0; i < at_.size(); ++i) {
      if (p > 0) carriage_angles_jacobian(map, axis, at_[i], rows3.data());
      if (again_) {
        const auto r = static_cast<Eigen::Index>(i);
        for (std::size_t k = 0; k < p; ++k)
          j(r, static_cast<Eigen::Index>(k)) = rows3[static_cast<std::size_t>(axis) * p + k];
        j(r, static_cast<Eigen::Index>(p)) = 1.0;
        continue;
      }
      for (std::size_t c = 0; c < 3; ++c) {
        const auto r = static_cast<Eigen::Index>(3 * i + c);
        for (std::size_t k = 0; k < p; ++k) j(r, static_cast<Eigen::Index>(k)) = rows3[c * p + k];
        j(r, static_cast<Eigen::Index>(p + c)) = 1.0;
      }
    }
  }
  void predict(const ErrorMap& map, const double* nu, double* out) const override {
    for (std::size_t i = 0; i < at_.size(); ++i) {
      const Vec3 a = carriage_angles(map, axis, at_[i]);
      if (again_) {
        out[i] = a[static_cast<std::size_t>(axis)] + nu[0];
        continue;
      }
      for (std::size_t c = 0; c < 3; ++c) out[3 * i + c] = a[c] + nu[c];
    }
  }

 private:
  bool again_;
  std::vector<Vec3> at_;
};

// ---- The autocollimator traverse of a carriage ----

class Traverse : public Group {
 public:
  Traverse(const TraverseTest& t, const ErrorMap& map) {
    kind = GroupKind::traverse;
    axis = t.axis;
    test = "traverse " + axis_upper(axis);
    name = test;
    unit = "arcsec";
    unit_per_si = 1.0 / rad_per_arcsec;
    Vec3 mid{};
    for (std::size_t a = 0; a < 3; ++a) mid[a] = 0.5 * (map.travel[a].lo_m + map.travel[a].hi_m);
    const std::size_t channels = t.yaw_rad.empty() ? 1 : 2;
    const int comp[2] = {pitch_component(axis) - 3, yaw_component(axis) - 3};
    std::map<int, std::size_t> pass_index;
    for (int p : t.pass) pass_index.emplace(p, 0);
    std::size_t k = 0;
    for (auto& [p, index] : pass_index) index = k++;
    const std::size_t passes = pass_index.size();
    drift_ = !t.t_s.empty() && passes >= 2;
    const double t_mid = drift_ ? 0.5 * (*std::min_element(t.t_s.begin(), t.t_s.end()) +
                                         *std::max_element(t.t_s.begin(), t.t_s.end()))
                                : 0.0;
    for (std::size_t i = 0; i < t.position_m.size(); ++i) {
      Vec3 at = mid;
      at[static_cast<std::size_t>(axis)] = t.position_m[i];
      for (std::size_t c = 0; c < channels; ++c) {
        at_.push_back(at);
        component_.push_back(comp[c]);
        offset_.push_back(pass_index[t.pass[i]] * channels + c);
        channel_.push_back(c);
        time_.push_back(drift_ ? t.t_s[i] - t_mid : 0.0);
        y.push_back(c == 0 ? t.pitch_rad[i] : t.yaw_rad[i]);
        sigma.push_back(std::max(t.u_angle_rad, sigma_floor_rad));
      }
    }
    const char* channel_name[2] = {"pitch", "yaw"};
    for (const auto& [p, index] : pass_index)
      for (std::size_t c = 0; c < channels; ++c)
        nuisance_names.push_back(test + " pass " + std::to_string(p) + " " + channel_name[c] + " zero");
    offsets_ = nuisance_names.size();
    if (drift_)
      for (std::size_t c = 0; c < channels; ++c) nuisance_names.push_back(test + " " + channel_name[c] + " drift");
  }
  void jacobian(const ErrorMap& map, MatrixXd& j) const override {
    const std::size_t p = map.parameters;
    j.setZero(static_cast<Eigen::Index>(rows()), static_cast<Eigen::Index>(p + nuisance()));
    std::vector<double> rows3(3 * p);
    for (std::size_t i = 0; i < rows(); ++i) {
      const auto r = static_cast<Eigen::Index>(i);
      if (p > 0) carriage_angles_jacobian(map, axis, at_[i], rows3.data());
      for (std::size_t k = 0; k < p; ++k)
        j(r, static_cast<Eigen::Index>(k)) = rows3[static_cast<std::size_t>(component_[i]) * p + k];
      j(r, static_cast<Eigen::Index>(p + offset_[i])) = 1.0;
      if (drift_) j(r, static_cast<Eigen::Index>(p + offsets_ + channel_[i])) = time_[i];
    }
  }
  void predict(const ErrorMap& map, const double* nu, double* out) const override {
    for (std::size_t i = 0; i < rows(); ++i) {
      double v = carriage_angles(map, axis, at_[i])[static_cast<std::size_t>(component_[i])] + nu[offset_[i]];
      if (drift_) v += nu[offsets_ + channel_[i]] * time_[i];
      out[i] = v;
    }
  }

 private:
  bool drift_ = false;
  std::size_t offsets_ = 0;
  std::vector<Vec3> at_;
  std::vector<int> component_;
  std::vector<std::size_t> offset_, channel_;
  std::vector<double> time_;
};

// ---- The ballbar's runs in one plane ----

// What the bar reads at one sample: dL = |r u + h n + E(P) + play + centre offset| - L0 + the run's constant.
struct BarSample {
  std::size_t run = 0;
  Vec3 at{};            // commanded (or encoder) position of the axes
  Vector3d nominal;     // r u + h n: the bar's nominal vector, fixed ball to moving ball
  Vector3d g;           // its direction (nominal / L0)
  double l0 = 0.0;
  double lost_a = 0.0;  // deadband of a along a per unit backlash (ideal step: -sign(v) / 2)
  double lost_b = 0.0;
  double play_a = 0.0;  // a's carriage shifted along b per unit play: sign(v_a) / 2
  double play_b = 0.0;
  double servo = 0.0;   // a lag mismatch's signature, dir sin 2 zeta (commanded angles only)
  double zeta = 0.0, radius = 0.0, dir = 1.0;
};

class BallbarPlane : public Group {
 public:
  BallbarPlane(const std::string& plane_name, const std::vector<const formats::DbbRun*>& runs, const Vec3& tool,
               std::size_t per_run, std::array<double, 2> deadband)
      : tool_(tool), axes_(plane_axes(plane_name)) {
    kind = GroupKind::ballbar;
    plane = plane_name;
    test = "ballbar " + plane;
    name = test;
    unit = "um";
    unit_per_si = 1e6;
    const Vector3d ea = Vector3d::Unit(axes_[0]), eb = Vector3d::Unit(axes_[1]);
    const Vector3d n = ea.cross(eb);
    for (std::size_t k = 0; k < runs.size(); ++k) {
      const formats::DbbRun& run = *runs[k];
      const auto src = run.metadata.find("angle_source");
      if (src == run.metadata.end() || src->second != "encoders") servo_ = true;
      Vec3 center{};
      center[static_cast<std::size_t>(axes_[0])] = run.center_a_m;
      center[static_cast<std::size_t>(axes_[1])] = run.center_b_m;
      center[static_cast<std::size_t>(axes_[2])] = run_center_n_m(run);
      const std::size_t count = run.angle_rad.size();
      const std::size_t stride = std::max<std::size_t>(1, (count + per_run - 1) / std::max<std::size_t>(per_run, 1));
      const double l0 = run.nominal_length_m();
      for (std::size_t i = 0; i < count; i += stride) {
        BarSample s;
        s.run = k;
        s.zeta = run.angle_rad[i];
        s.radius = run.radius_m;
        s.dir = run.dir();
        const double c = std::cos(s.zeta), si = std::sin(s.zeta);
        s.at = center;
        s.at[static_cast<std::size_t>(axes_[0])] += run.radius_m * c;
        s.at[static_cast<std::size_t>(axes_[1])] += run.radius_m * si;
        s.nominal = run.radius_m * (c * ea + si * eb) + run.height_m * n;
        s.l0 = l0;
        s.g = s.nominal / l0;
        const double va = dbb::velocity_sign_a(s.dir, si), vb = dbb::velocity_sign_b(s.dir, c);
        // The drives reverse where the angles say (a live session's angles are the encoders'); the carriage
        // stands still until the drive has risen the deadband's width from its extreme.
        const double rise_a = dbb::rise_since_reversal_m(
            run.radius_m, dbb::angle_since_reversal_rad(s.zeta, 0.0, s.dir));
        const double rise_b = dbb::rise_since_reversal_m(
            run.radius_m, dbb::angle_since_reversal_rad(s.zeta, 0.5 * std::numbers::pi, s.dir));
        s.lost_a = dbb::deadband_lost_motion(va, rise_a, deadband[0]);
        s.lost_b = dbb::deadband_lost_motion(vb, rise_b, deadband[1]);
        s.play_a = 0.5 * va;
        s.play_b = 0.5 * vb;
        s.servo = s.dir * std::sin(2.0 * s.zeta);
        samples_.push_back(s);
        y.push_back(run.dL_m[i]);
        sigma.push_back(0.1e-6);  // a ballbar's noise, until the fit has estimated the runs' own
      }
      nuisance_names.push_back(test + " run " + std::to_string(k + 1) + " length");
      nuisance_names.push_back(test + " run " + std::to_string(k + 1) + " centre " + axis_name(axes_[0]));
      nuisance_names.push_back(test + " run " + std::to_string(k + 1) + " centre " + axis_name(axes_[1]));
    }
    plane0_ = nuisance_names.size();
    for (const char* what : {"backlash ", "play "})
      for (int a = 0; a < 2; ++a) nuisance_names.push_back(test + " " + what + axis_name(axes_[static_cast<std::size_t>(a)]));
    if (servo_) nuisance_names.push_back(test + " servo mismatch");
  }
  void jacobian(const ErrorMap& map, MatrixXd& j) const override {
    const std::size_t p = map.parameters;
    j.setZero(static_cast<Eigen::Index>(rows()), static_cast<Eigen::Index>(p + nuisance()));
    std::vector<double> rows3(3 * p);
    for (std::size_t i = 0; i < samples_.size(); ++i) {
      const BarSample& s = samples_[i];
      const auto r = static_cast<Eigen::Index>(i);
      if (p > 0) tool_error_jacobian(map, s.at, tool_, rows3.data());
      for (std::size_t k = 0; k < p; ++k)
        j(r, static_cast<Eigen::Index>(k)) = s.g[0] * rows3[k] + s.g[1] * rows3[p + k] + s.g[2] * rows3[2 * p + k];
      for (const auto& [col, value] : nuisance_row(s)) j(r, static_cast<Eigen::Index>(p + col)) = value;
    }
  }
  void predict(const ErrorMap& map, const double* nu, double* out) const override {
    const auto a = static_cast<Eigen::Index>(axes_[0]), b = static_cast<Eigen::Index>(axes_[1]);
    for (std::size_t i = 0; i < samples_.size(); ++i) {
      const BarSample& s = samples_[i];
      Vector3d bar = s.nominal + v3(tool_error(map, s.at, tool_));
      const double* run = nu + 3 * s.run;
      bar[a] += run[1] + nu[plane0_] * s.lost_a + nu[plane0_ + 3] * s.play_b;
      bar[b] += run[2] + nu[plane0_ + 1] * s.lost_b + nu[plane0_ + 2] * s.play_a;
      double v = bar.norm() - s.l0 + run[0];
      if (servo_) v += nu[plane0_ + 4] * s.servo;
      out[i] = v;
    }
  }
  [[nodiscard]] const std::vector<BarSample>& samples() const { return samples_; }
  [[nodiscard]] std::size_t backlash_term() const { return plane0_; }
  [[nodiscard]] const std::array<int, 3>& axes() const { return axes_; }

 private:
  // The group's own columns at a sample, to first order: the run's length and centre, the planes' play.
  [[nodiscard]] std::vector<std::pair<std::size_t, double>> nuisance_row(const BarSample& s) const {
    const double ga = s.g[axes_[0]], gb = s.g[axes_[1]];
    std::vector<std::pair<std::size_t, double>> row = {{3 * s.run, 1.0},
                                                       {3 * s.run + 1, ga},
                                                       {3 * s.run + 2, gb},
                                                       {plane0_, ga * s.lost_a},
                                                       {plane0_ + 1, gb * s.lost_b},
                                                       {plane0_ + 2, gb * s.play_a},
                                                       {plane0_ + 3, ga * s.play_b}};
    if (servo_) row.emplace_back(plane0_ + 4, s.servo);
    return row;
  }

  Vec3 tool_;
  std::array<int, 3> axes_;
  std::size_t plane0_ = 0;
  bool servo_ = false;
  std::vector<BarSample> samples_;
};

}  // namespace

std::optional<std::array<double, 2>> backlash_of(const Group& group, const double* nuisance) {
  const auto* plane = dynamic_cast<const BallbarPlane*>(&group);
  if (plane == nullptr) return std::nullopt;
  return std::array<double, 2>{nuisance[plane->backlash_term()], nuisance[plane->backlash_term() + 1]};
}

std::vector<std::unique_ptr<Group>> make_groups(const MapInputs& inputs, const ErrorMap& map,
                                                std::size_t ballbar_samples_per_run, const DeadbandWidths& deadbands) {
  std::vector<std::unique_ptr<Group>> groups;
  for (const auto& a : inputs.artifacts) {
    if (a.axis < 0 || a.axis > 2) throw std::invalid_argument(a.source + ": the artifact's axis must be x, y or z");
    if (a.position_m.size() < 3) throw std::invalid_argument(a.source + ": the map needs an artifact of 3 targets or more");
    groups.push_back(std::make_unique<ArtifactDisplacements>(a, map.tool_offset_m));
    groups.push_back(std::make_unique<ArtifactAngles>(a, false));
    groups.push_back(std::make_unique<ArtifactAngles>(a, true));
  }
  for (const auto& t : inputs.traverses) {
    if (t.axis < 0 || t.axis > 2) throw std::invalid_argument(t.source + ": the traverse's axis must be x, y or z");
    groups.push_back(std::make_unique<Traverse>(t, map));
  }
  std::map<std::string, std::vector<const formats::DbbRun*>> planes;
  for (const auto& r : inputs.ballbar_runs) planes[r.plane].push_back(&r);
  for (const auto& [plane, runs] : planes) {
    const auto w = deadbands.find(plane);
    groups.push_back(std::make_unique<BallbarPlane>(plane, runs, map.tool_offset_m, ballbar_samples_per_run,
                                                    w == deadbands.end() ? std::array<double, 2>{} : w->second));
  }
  return groups;
}

LocalModel local_model(const Group& group) {
  const auto* plane = dynamic_cast<const BallbarPlane*>(&group);
  if (plane == nullptr) throw std::invalid_argument("local_model: not a ballbar plane");
  const auto axes = plane->axes();
  const std::string a = axis_name(axes[0]), b = axis_name(axes[1]);
  LocalModel m;
  m.names = {"squareness_urad", "straightness_" + a + "_um", "straightness_" + b + "_um",
             "straightness_cubic_" + a + "_minus_" + b + "_um", "scale_mismatch_ppm"};
  m.unit_per_si = {1e6, 1e6, 1e6, 1e6, 1e6};
  const auto& samples = plane->samples();
  m.columns.setZero(static_cast<Eigen::Index>(samples.size()), 5);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const BarSample& s = samples[i];
    const double c = std::cos(s.zeta), si = std::sin(s.zeta);
    const double da = s.radius * c, db = s.radius * si;  // from the circle's centre
    const double ga = s.g[axes[0]], gb = s.g[axes[1]];
    const auto r = static_cast<Eigen::Index>(i);
    m.columns(r, 0) = ga * db;                                     // actual a = a + q b
    m.columns(r, 1) = gb * c * c;                                  // a deviates along b by B (a / r)^2
    m.columns(r, 2) = ga * si * si;                                // b deviates along a by B (b / r)^2
    m.columns(r, 3) = 0.5 * (gb * c * c * c - ga * si * si * si);  // K/2 (a/r)^3 along b, -K/2 (b/r)^3 along a
    m.columns(r, 4) = 0.5 * (ga * da - gb * db);                   // s_a - s_b, split evenly
  }
  return m;
}

std::string axis_upper(int axis) { return std::string(1, "XYZ"[axis]); }

}  // namespace guideway::models::map::detail
