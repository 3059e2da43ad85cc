// The 1-D artifact identification as JSON (artifact_json.hpp): units in the key names, uncertainties as "u_<name>".
#include "models/artifact/artifact_json.hpp"
#include "core/units.hpp"

#include <numbers>

namespace guideway::models::artifact {

namespace {

constexpr double arcsec = rad_per_arcsec;

nlohmann::json placement_json(const ArtifactPlacementValues& v) {
  nlohmann::json j = nlohmann::json::array();
  for (std::size_t i = 0; i < v.X_F_m.size(); ++i)
    j.push_back({{"theta_x_arcsec", v.theta_x_rad[i] / arcsec},
                 {"theta_y_arcsec", v.theta_y_rad[i] / arcsec},
                 {"X_F_mm", v.X_F_m[i] * 1e3},
                 {"Y_F_mm", v.Y_F_m[i] * 1e3}});
  return j;
}

nlohmann::json scan_json(const ConversionFit& f, double slope_scale, const char* slope_name) {
  return {{"source", f.source},
          {"points", f.points},
          {slope_name, f.slope * slope_scale},
          {std::string("u_") + slope_name, f.u_slope * slope_scale},
          {"intercept_px", f.intercept_px},
          {"residual_rms_px", f.residual_rms_px}};
}

}  // namespace

nlohmann::json to_json(const ArtifactResult& r) {
  nlohmann::json j;
  j["k_um_per_px"] = r.k_m_per_px * 1e6;
  j["u_k_um_per_px"] = r.u_k_m_per_px * 1e6;
  j["m_px_per_arcsec"] = r.m_px_per_rad * arcsec;
  j["u_m_px_per_arcsec"] = r.u_m_px_per_rad * arcsec;
  j["coupling_um_per_arcsec"] = r.coupling_m_per_rad * 1e6 * arcsec;
  if (r.k_scan) j["k_scan"] = scan_json(*r.k_scan, 1e-6, "slope_px_per_um");
  if (r.m_scan) j["m_scan"] = scan_json(*r.m_scan, arcsec, "slope_px_per_arcsec");
  j["calibration"] = placement_json(r.calibration);
  j["horizontal"] = placement_json(r.horizontal);
  j["vertical"] = placement_json(r.vertical);
  // Every key names a machine direction: for an artifact along Y, y_mm is the position, dy_um its positioning
  // error and ey_arcsec its roll (machine_errors).
  const std::string a(1, "xyz"[r.axis]);
  j["axis"] = a;
  nlohmann::json t = nlohmann::json::array();
  for (const auto& e : r.targets) {
    const MachineErrors m = machine_errors(e, r.axis);
    nlohmann::json row = {{"target", e.target}, {a + "_mm", e.x_m * 1e3}};
    for (std::size_t i = 0; i < 3; ++i) {
      const std::string d(1, "xyz"[i]);
      row["d" + d + "_um"] = m.d[i] * 1e6;
      row["u_d" + d + "_um"] = m.u_d[i] * 1e6;
    }
    for (std::size_t i = 0; i < 3; ++i) {
      const std::string d(1, "xyz"[i]);
      row["e" + d + "_arcsec"] = m.r[i] / arcsec;
      row["u_e" + d + "_arcsec"] = m.u_r[i] / arcsec;
    }
    row["e" + a + "_vertical_arcsec"] = e.ex_vertical_rad / arcsec;
    row["u_e" + a + "_vertical_arcsec"] = e.u_ex_vertical_rad / arcsec;
    t.push_back(row);
  }
  j["targets"] = t;
  return j;
}

}  // namespace guideway::models::artifact
