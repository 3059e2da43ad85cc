#include "models/explain/effects/dbb_terms.hpp"

#include <algorithm>
#include <numbers>

#include "models/dbb/fast_sincos.hpp"

namespace guideway::models::explain::effects {

std::vector<double> drive_delays_s(const std::vector<formats::DbbRun>& runs) {
  const bool encoders = std::all_of(runs.begin(), runs.end(), [](const formats::DbbRun& r) {
    const auto it = r.metadata.find("angle_source");
    return it != r.metadata.end() && it->second == "encoders";
  });
  if (encoders) return {0.0};
  return {0.0, 5e-3, 10e-3, 15e-3, 20e-3, 25e-3, 30e-3, 40e-3, 50e-3, 60e-3, 80e-3, 100e-3};
}

std::shared_ptr<const std::vector<DriveTrack>> drive_tracks(const std::vector<Geo>& g,
                                                            const std::vector<double>& delays) {
  auto out = std::make_shared<std::vector<DriveTrack>>();
  for (const double d : delays) {
    DriveTrack t;
    t.delay_s = d;
    for (const Geo& p : g) {
      const double z = p.zeta_rad - p.dir * p.omega_rad_per_s * d;
      double s = 0, c = 0;
      dbb::fast_sincos(z, s, c);
      const auto rise = [&](double phase) {
        return dbb::rise_since_reversal_m(p.radius_m, dbb::angle_since_reversal_rad(z, phase, p.dir));
      };
      t.pos_a.push_back(p.center_a_m + p.radius_m * c);
      t.pos_b.push_back(p.center_b_m + p.radius_m * s);
      t.vel_a.push_back(dbb::velocity_sign_a(p.dir, s));
      t.vel_b.push_back(dbb::velocity_sign_b(p.dir, c));
      t.rise_a.push_back(rise(0.0));
      t.rise_b.push_back(rise(std::numbers::pi / 2));
    }
    out->push_back(std::move(t));
  }
  return out;
}

std::array<double, 2> lost_motion(const DriveTrack& t, std::size_t i, double b_a, double b_b) {
  return {dbb::deadband_lost_motion(t.vel_a[i], t.rise_a[i], b_a),
          dbb::deadband_lost_motion(t.vel_b[i], t.rise_b[i], b_b)};
}

}  // namespace guideway::models::explain::effects
