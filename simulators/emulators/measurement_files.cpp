// Offline measurement files from the virtual machine tool (measurement_files.hpp), in the formats `guideway identify`
// reads.
#include "simulators/emulators/measurement_files.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>
#include <stdexcept>

#include "core/units.hpp"
#include "formats/profile_files.hpp"
#include "models/artifact/artifact.hpp"

namespace guideway::simulators::emulators {

namespace {

constexpr double arcsec = rad_per_arcsec;

std::uint64_t seed_of(const machine::Machine& machine, std::uint64_t seed) {
  return seed != 0 ? seed : machine.config().noise.seed;
}

// Shortest text that reads back to the same double.
std::string number(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// Set-up values for metadata lines: 15 significant digits hide the unit conversion's last bit.
std::string setting(double v) {
  std::ostringstream s;
  s.precision(15);
  s << v;
  return s.str();
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out.flush()) throw std::runtime_error(path + ": cannot write");
}

std::string feed_label(double feed) {
  std::ostringstream s;
  s << feed;
  return s.str();
}

}  // namespace

std::string workpiece_profile_csv(const machine::Machine& machine, const WorkpieceFilesSpec& spec,
                                  double feed_mm_per_min) {
  machine::FacingSpec f;
  f.x_start_m = spec.x_start_m;
  f.x_end_m = spec.x_start_m + spec.traverse_m;
  f.feed_m_per_s = feed_mm_per_min * 1e-3 / 60.0;
  f.spindle_rpm = spec.spindle_rpm;
  f.profile_step_m = spec.profile_step_m;
  f.seed = seed_of(machine, spec.seed) + static_cast<std::uint64_t>(std::llround(feed_mm_per_min * 1000));
  formats::Profile p;
  for (const auto& pt : machine.facing_profile(f)) {
    p.x_m.push_back(pt.x_m);
    p.z_m.push_back(pt.z_m);
  }
  p.metadata = {{"feed_mm_per_min", number(feed_mm_per_min)},
                {"spindle_rpm", number(spec.spindle_rpm)},
                {"machine", machine.config().name},
                {"source", "guideway-emulate workpiece (simulators::machine::Machine::facing_profile)"}};
  return formats::format_profile_csv(p);
}

std::string straightness_traverse_csv(const machine::Machine& machine, const WorkpieceFilesSpec& spec) {
  machine::TraverseSpec t;
  t.axis = machine::Axis::x;
  t.start_m = spec.x_start_m + spec.step_m / 2;  // the mirror sits midway between the reflector's feet
  t.end_m = spec.x_start_m + spec.traverse_m - spec.step_m / 2;
  t.step_m = spec.step_m;
  t.seed = seed_of(machine, spec.seed) + 1;
  std::ostringstream out;
  out << "# step_mm = " << setting(spec.step_m * 1e3) << "\n# machine = " << machine.config().name
      << (spec.passes > 1 ? "\nx_mm,pitch_arcsec,yaw_arcsec,t_s,pass\n" : "\nx_mm,pitch_arcsec,yaw_arcsec\n");
  // Rotation about +y is minus the slope of the vertical path, rotation about +z plus the slope of the
  // horizontal one (docs/formats.md, Straightness traverse). Several passes: forward and back, each
  // reading with its time and its pass.
  t.dwell_s = spec.dwell_s;
  const auto passes = machine.autocollimator_passes(t, spec.passes, spec.turn_s);
  for (std::size_t k = 0; k < passes.size(); ++k)
    for (const auto& s : passes[k]) {
      out << number((s.position_m - spec.step_m / 2) * 1e3) << "," << number(-s.pitch_rad / arcsec) << ","
          << number(s.yaw_rad / arcsec);
      if (spec.passes > 1) out << "," << number(s.t_s) << "," << k + 1;
      out << "\n";
    }
  return out.str();
}

std::string runout_revolution_csv(const machine::Machine& machine, const WorkpieceFilesSpec& spec) {
  machine::RunoutSpec r;
  r.probe_radius_m = spec.probe_radius_m;
  r.samples_per_rev = 360;
  r.rpm = spec.spindle_rpm;
  r.seed = seed_of(machine, spec.seed) + 2;
  const double parallelism_m =
      spec.parallelism_m.value_or(machine.config().spindle.plate_parallelism_rad * 2 * spec.probe_radius_m);
  std::ostringstream out;
  out << "# plate_diameter_mm = " << setting(2 * spec.probe_radius_m * 1e3)
      << "\n# parallelism_um = " << setting(parallelism_m * 1e6) << "\n# travel_mm = " << setting(spec.traverse_m * 1e3)
      << "\n# machine = " << machine.config().name << "\nangle_deg,runout_um\n";
  for (const auto& s : machine.runout_revolution(r))
    out << number(s.angle_rad * 180.0 / std::numbers::pi) << "," << number(s.displacement_m * 1e6) << "\n";
  return out.str();
}

std::vector<std::string> write_workpiece_files(const machine::Machine& machine, const WorkpieceFilesSpec& spec,
                                               const std::vector<double>& feeds_mm_per_min, const std::string& dir) {
  std::vector<std::string> paths;
  for (double feed : feeds_mm_per_min) {
    paths.push_back(dir + "/profile_" + feed_label(feed) + "mm_per_min.csv");
    write_file(paths.back(), workpiece_profile_csv(machine, spec, feed));
  }
  paths.push_back(dir + "/straightness.csv");
  write_file(paths.back(), straightness_traverse_csv(machine, spec));
  paths.push_back(dir + "/runout.csv");
  write_file(paths.back(), runout_revolution_csv(machine, spec));
  return paths;
}

ArtifactFiles artifact_files(const machine::Machine& machine, const ArtifactFilesSpec& spec) {
  if (spec.targets < 2) throw std::invalid_argument("artifact files: need at least 2 targets");
  const std::size_t n = spec.targets;
  const double k = spec.k_m_per_px;
  const double m = spec.m_px_per_rad;

  // The artifact: feature points (along, across) and mirror tilts (about x, about the artifact's y).
  std::vector<double> a(n), b(n), tx(n), ty(n);
  {
    std::mt19937_64 rng(spec.artifact_seed);
    std::normal_distribution<double> g(0.0, 1.0);
    for (std::size_t i = 0; i < n; ++i) {
      a[i] = spec.start_m + static_cast<double>(i) * spec.pitch_m + spec.position_scatter_m * g(rng);
      b[i] = spec.position_scatter_m * g(rng);
      tx[i] = spec.tilt_scatter_rad * g(rng);
      ty[i] = spec.tilt_scatter_rad * g(rng);
    }
  }
  const std::uint64_t seed = seed_of(machine, spec.seed);
  // The artifact lies along the axis; each placement reads across another machine axis (models/artifact's
  // across_axis: X horizontal y, vertical z; Y horizontal x, vertical z; Z x and y).
  const auto j = static_cast<std::size_t>(spec.axis);
  const std::size_t across_of[3] = {
      static_cast<std::size_t>(models::artifact::across_axis(static_cast<int>(j), models::artifact::ArtifactPlacement::horizontal)),
      static_cast<std::size_t>(models::artifact::across_axis(static_cast<int>(j), models::artifact::ArtifactPlacement::horizontal)),
      static_cast<std::size_t>(models::artifact::across_axis(static_cast<int>(j), models::artifact::ArtifactPlacement::vertical))};
  const auto column = [](std::size_t axis) { return std::string(1, "XYZ"[axis]) + "_M_mm"; };

  // placement 0: calibration (perfect reference), 1: horizontal, 2: vertical.
  auto file = [&](int placement) {
    std::vector<machine::ArtifactTarget> t;
    if (placement > 0) {
      machine::ArtifactSpec as;
      as.axis = spec.axis;
      as.start_m = spec.start_m;
      as.pitch_m = spec.pitch_m;
      as.targets = n;
      as.other = spec.other;
      as.seed = seed + static_cast<std::uint64_t>(placement);
      t = machine.artifact_measurement(as);
    }
    std::mt19937_64 rng(seed * 7919 + static_cast<std::uint64_t>(placement) * 104729 + 17);
    std::normal_distribution<double> g(0.0, 1.0);
    const char* names[] = {"calibration", "horizontal", "vertical"};
    std::ostringstream out;
    out << "# format = guideway/artifact/1\n# placement = " << names[placement] << "\n# axis = " << "xyz"[j] << "\n";
    if (placement == 0)
      out << "# k_um_per_px = " << setting(k * 1e6) << "\n# m_px_per_arcsec = " << setting(m * arcsec) << "\n";
    out << "# u_spot_px = " << setting(spec.spot_noise_px)
        << "\n# u_position_um = " << setting(placement == 0 ? spec.laser_noise_m * 1e6 : 0.0)
        << "\n# machine = " << machine.config().name << "\n";
    const std::size_t across = across_of[placement];
    out << "target," << column(j) << "," << column(across) << ",x_M_px,y_M_px,x_F_px,y_F_px\n";
    for (std::size_t i = 0; i < n; ++i) {
      // Commanded measurement point over the nominal target; the sensor's actual error there.
      const double c_along = spec.start_m + static_cast<double>(i) * spec.pitch_m;
      const double c_across = spec.other[across];
      double d_along = 0, d_across = 0, tilt_x_img = 0, tilt_y_img = 0;
      if (placement > 0) {
        d_along = t[i].displacement_m[j];
        d_across = t[i].displacement_m[across];
        tilt_x_img = t[i].rotation_rad[across];  // about the image's y axis (the placement's across axis)
        tilt_y_img = t[i].rotation_rad[j];       // about the artifact (roll)
      }
      const double xF = m * (ty[i] + tilt_x_img);
      const double yF = m * (tx[i] + tilt_y_img);
      // Paraboloid: the spot offset from the mirror's is the lateral distance of the beam from the
      // feature point over k, plus the sensor's tilt (the angle coupling Wei correct by k m epsilon).
      // Each spot is extracted from its own image: independent noise.
      const double xM = xF - (a[i] - c_along - d_along + k * m * tilt_x_img) / k + spec.spot_noise_px * g(rng);
      const double yM = yF - (b[i] - c_across - d_across + k * m * tilt_y_img) / k + spec.spot_noise_px * g(rng);
      const double xF_read = xF + spec.spot_noise_px * g(rng);
      const double yF_read = yF + spec.spot_noise_px * g(rng);
      double X = c_along, Y = c_across;
      if (placement == 0) {
        X += spec.laser_noise_m * g(rng);
        Y += spec.laser_noise_m * g(rng);
      }
      out << i << "," << number(X * 1e3) << "," << number(Y * 1e3) << "," << number(xM) << "," << number(yM) << ","
          << number(xF_read) << "," << number(yF_read) << "\n";
    }
    return out.str();
  };
  // Wei Sec. 3.2's calibration of k and m on the reference, at target 0.
  std::mt19937_64 rng(seed * 7919 + 3 * 104729 + 17);
  std::normal_distribution<double> g(0.0, 1.0);
  std::ostringstream ks, ms;
  ks << "# format = guideway/artifact-scan/1\n# scan = displacement\nX_M_mm,x_M_px\n";
  ms << "# format = guideway/artifact-scan/1\n# scan = angle\ntheta_arcsec,x_F_px\n";
  for (int j = -10; j <= 10; ++j) {
    const double X = spec.start_m + 5e-6 * j;  // beam position across the paraboloid
    const double xM = m * ty[0] - (a[0] - X) / k + spec.spot_noise_px * g(rng);
    ks << number((X + spec.laser_noise_m * g(rng)) * 1e3) << "," << number(xM) << "\n";
    const double theta = 2.0 * arcsec * j;
    ms << number(theta / arcsec) << "," << number(m * (ty[0] + theta) + spec.spot_noise_px * g(rng)) << "\n";
  }
  return {file(0), file(1), file(2), ks.str(), ms.str()};
}

std::vector<std::string> write_artifact_files(const machine::Machine& machine, const ArtifactFilesSpec& spec,
                                              const std::string& dir) {
  const auto f = artifact_files(machine, spec);
  std::vector<std::string> paths{dir + "/calibration.csv", dir + "/horizontal.csv", dir + "/vertical.csv",
                                 dir + "/k_scan.csv", dir + "/m_scan.csv"};
  write_file(paths[0], f.calibration);
  write_file(paths[1], f.horizontal);
  write_file(paths[2], f.vertical);
  write_file(paths[3], f.k_scan);
  write_file(paths[4], f.m_scan);
  return paths;
}

}  // namespace guideway::simulators::emulators
