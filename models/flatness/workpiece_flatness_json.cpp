// The workpiece flatness analysis as JSON (workpiece_flatness_json.hpp): units in the key names, uncertainties as
// "u_<name>".
#include "models/flatness/workpiece_flatness_json.hpp"

#include <cmath>
#include <string>
#include <string_view>

#include "models/flatness/json.hpp"
#include "results/parameters.hpp"

namespace guideway::models::flatness {

namespace {

constexpr double um = 1e6;
constexpr double urad = 1e6;

// The squareness of the spindle to the X axis is one quantity however it is measured (a faced profile's slope
// here, Eq. 21's run-out on a thrust plate in runout_check): named by its one catalogue entry, its u "u_" before.
std::string squareness_key(std::string_view prefix = {}) {
  return std::string(prefix) + results::name(results::runout_squareness);
}

nlohmann::json profile_json(const ProfileFlatness& p) {
  nlohmann::json j;
  j["source"] = p.source;
  j["feed_mm_per_min"] = p.feed_m_per_s * 60e3;
  j["spindle_rpm"] = p.spindle_rpm;
  j["points"] = p.points;
  j["spacing_mm"] = p.spacing_m * 1e3;
  j["x_start_mm"] = p.x_start_m * 1e3;
  j["x_end_mm"] = p.x_end_m * 1e3;
  j["peak_to_valley_um"] = p.peak_to_valley_m * um;
  j["low_frequency_peak_to_valley_um"] = p.low_frequency_peak_to_valley_m * um;
  nlohmann::json bands = nlohmann::json::array();
  for (double b : p.band_rms_m) bands.push_back(b * um);
  j["band_rms_um"] = bands;
  nlohmann::json c = nlohmann::json::object();
  for (const auto& k : p.correlations) c[k.name] = {{"gamma_before", k.gamma_before}, {"gamma_after", k.gamma_after}};
  j["correlation"] = c;
  j["dominant"] = p.dominant;
  j["impact_factor"] = p.impact_factor;
  j[squareness_key()] = p.squareness_rad * urad;
  j[squareness_key("u_")] = p.u_squareness_rad * urad;
  j["u_fit_urad"] = p.u_fit_rad * urad;
  j["u_straightness_urad"] = p.u_straightness_rad * urad;
  j["residual_rms_um"] = p.residual_rms_m * um;
  j["residual_lag1_correlation"] = p.residual_lag1_correlation;
  j["squareness_amplitude_um"] = p.squareness_amplitude_m * um;
  j["u_squareness_amplitude_um"] = p.u_squareness_amplitude_m * um;
  return j;
}

}  // namespace

nlohmann::json to_json(const WorkpieceFlatnessResult& r) {
  nlohmann::json j;
  j["wavelet"] = r.wavelet;
  j["levels"] = r.levels;
  nlohmann::json s;
  s["source"] = r.straightness_source;
  s["x_start_mm"] = r.straightness_x0_m * 1e3;
  s["x_end_mm"] = r.straightness_x_end_m * 1e3;
  s["order"] = r.straightness.order;
  // Eq. 10 in Mu's units (height mm, x mm from x_start_mm), as Eq. 17 prints it.
  nlohmann::json b = nlohmann::json::array(), ub = nlohmann::json::array();
  for (std::size_t k = 0; k < r.straightness.b.size(); ++k) {
    const double scale = 1e3 / std::pow(1e3, static_cast<double>(k));
    b.push_back(r.straightness.b[k] * scale);
    ub.push_back(k < r.straightness.u_b.size() ? r.straightness.u_b[k] * scale : 0.0);
  }
  s["b_mm"] = b;
  s["u_b_mm"] = ub;
  s["residual_rms_um"] = r.straightness.residual_rms_m * um;
  j["straightness"] = s;
  nlohmann::json ps = nlohmann::json::array();
  for (const auto& p : r.profiles) ps.push_back(profile_json(p));
  j["profiles"] = ps;
  j["dominant"] = r.dominant;
  j["impact_factor"] = r.impact_factor;
  j[squareness_key()] = r.squareness_rad * urad;
  j[squareness_key("u_")] = r.u_squareness_rad * urad;
  j["travel_mm"] = r.travel_m * 1e3;
  j["squareness_amplitude_um"] = r.squareness_amplitude_m * um;
  j["u_squareness_amplitude_um"] = r.u_squareness_amplitude_m * um;
  if (r.runout_check) {
    const auto& c = *r.runout_check;
    nlohmann::json k;
    k["runout"] = to_json(c.runout);
    k[squareness_key("eq21_")] = c.runout.deflection_rad * urad;
    k[squareness_key("u_eq21_")] = c.runout.u_deflection_rad * urad;
    k[squareness_key("profile_")] = c.profile_squareness_rad * urad;
    k[squareness_key("u_profile_")] = c.u_profile_squareness_rad * urad;
    k["difference_urad"] = c.difference_rad * urad;
    k["u_difference_urad"] = c.u_difference_rad * urad;
    k["eq21_amplitude_um"] = c.runout.deflection_rad * r.travel_m * um;
    k["consistent"] = c.consistent;
    j["runout_check"] = k;
  }
  return j;
}

}  // namespace guideway::models::flatness
