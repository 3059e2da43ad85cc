// The error map as a file (map_json.hpp, guideway/map/1): written by `map fit`, read back by export, compensate and
// report.
#include "models/map/map_json.hpp"

#include <cmath>
#include <stdexcept>

#include "core/csv_table.hpp"
#include "models/map/json_fields.hpp"

namespace guideway::models::map {

namespace {

constexpr double micro = 1e6;  // m -> um, rad -> urad

std::string unit_of(int component) { return component < 3 ? "um" : "urad"; }

using fields::fail;

nlohmann::json vec_mm(const Vec3& v) { return {v[0] * 1e3, v[1] * 1e3, v[2] * 1e3}; }

}  // namespace

const char* iso_squareness_name(int index) {
  static const char* names[] = {"EC0Y", "EB0Z", "EA0Z"};
  return names[index];
}

double iso_squareness_sign(int index) { return index == 1 ? 1.0 : -1.0; }

nlohmann::json to_json(const ErrorMap& m) {
  nlohmann::json j;
  j["format"] = map_format_id;
  j["machine"] = m.machine;
  std::string chain;
  for (int a : m.chain) chain += axis_name(a);
  j["chain"] = chain;
  j["tool_offset_mm"] = vec_mm(m.tool_offset_m);
  for (int a = 0; a < 3; ++a)
    j["travel_mm"][axis_name(a)] = {m.travel[static_cast<std::size_t>(a)].lo_m * 1e3,
                                    m.travel[static_cast<std::size_t>(a)].hi_m * 1e3};
  j["functions"] = nlohmann::json::array();
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < components; ++c) {
      const ErrorFunction& f = m.function(a, c);
      nlohmann::json fj = {{"name", function_name(a, c)},
                           {"axis", axis_name(a)},
                           {"role", role_name(role_of(a, c))},
                           {"unit", unit_of(c)},
                           {"determined", f.determined}};
      if (f.determined) {
        fj["determined_by"] = f.determined_by;
        fj["orders"] = f.orders;
        nlohmann::json co = nlohmann::json::array();
        for (double v : f.coefficients) co.push_back(v * micro);
        fj["coefficients"] = co;
        fj["first_parameter"] = f.first_parameter;
      } else {
        fj["why"] = f.why;
      }
      j["functions"].push_back(fj);
    }
  j["squareness"] = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) {
    const SquarenessTerm& q = m.squareness[static_cast<std::size_t>(i)];
    nlohmann::json qj = {{"plane", q.plane}, {"iso_name", iso_squareness_name(i)}, {"determined", q.determined}};
    if (q.determined) {
      qj["value_urad"] = q.value_rad * micro;
      qj["u_urad"] = std::sqrt(std::max(0.0, m.covariance_at(q.parameter, q.parameter))) * micro;
      qj["iso_value_urad"] = iso_squareness_sign(i) * q.value_rad * micro;
      qj["determined_by"] = q.determined_by;
      qj["parameter"] = q.parameter;
    } else {
      qj["why"] = q.why;
    }
    j["squareness"].push_back(qj);
  }
  j["parameters"] = m.parameters;
  nlohmann::json cov = nlohmann::json::array();
  for (std::size_t r = 0; r < m.parameters; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (std::size_t c = 0; c < m.parameters; ++c) row.push_back(m.covariance_at(r, c) * micro * micro);
    cov.push_back(row);
  }
  j["covariance"] = cov;
  return j;
}

nlohmann::json to_json(const VolumetricAccuracy& v) {
  nlohmann::json j = {{"value_um", v.value_m * micro},
                      {"u_um", v.u_m * micro},
                      {"u_spread_um", v.u_spread_m * micro},
                      {"u_bias_um", v.u_bias_m * micro},
                      {"at_mm", vec_mm(v.at_m)},
                      {"error_at_um", {v.error_at_m[0] * micro, v.error_at_m[1] * micro, v.error_at_m[2] * micro}},
                      {"E_VX_um", v.component_range_m[0] * micro},
                      {"E_VY_um", v.component_range_m[1] * micro},
                      {"E_VZ_um", v.component_range_m[2] * micro},
                      {"rms_um", v.rms_m * micro},
                      {"rigid_translation_um",
                       {v.rigid_translation_m[0] * micro, v.rigid_translation_m[1] * micro, v.rigid_translation_m[2] * micro}},
                      {"rigid_rotation_urad",
                       {v.rigid_rotation_rad[0] * micro, v.rigid_rotation_rad[1] * micro, v.rigid_rotation_rad[2] * micro}},
                      {"points", v.points},
                      {"tool_offset_mm", vec_mm(v.tool_offset_m)},
                      {"definition", volumetric_definition()}};
  j["missing"] = v.missing;
  j["complete"] = v.missing.empty();
  return j;
}

nlohmann::json to_json(const CrossCheck& c) {
  return {{"name", c.name},
          {"first", c.first},
          {"second", c.second},
          {"unit", c.unit},
          {"value_first", c.value_first},
          {"u_first", c.u_first},
          {"value_second", c.value_second},
          {"u_second", c.u_second},
          {"difference", c.difference},
          {"u_difference", c.u_difference},
          {"consistent", c.consistent},
          {"note", c.note}};
}

nlohmann::json to_json(const MapFit& fit, const std::optional<VolumetricAccuracy>& volumetric) {
  nlohmann::json j = to_json(fit.map);
  j["checks"] = nlohmann::json::array();
  for (const auto& c : fit.checks) j["checks"].push_back(to_json(c));
  j["groups"] = nlohmann::json::array();
  for (const auto& g : fit.groups)
    j["groups"].push_back({{"test", g.test},
                           {"unit", g.unit},
                           {"observations", g.observations},
                           {"residual_rms", g.residual_rms},
                           {"sigma", g.sigma}});
  j["notes"] = fit.notes;
  j["backlash"] = nlohmann::json::array();
  for (const auto& b : fit.backlash)
    j["backlash"].push_back(
        {{"axis", axis_name(b.axis)}, {"value_um", b.value_m * micro}, {"u_um", b.u_m * micro}, {"from", b.from}});
  if (volumetric) j["volumetric"] = to_json(*volumetric);
  return j;
}

ErrorMap map_from_json(const nlohmann::json& j, const std::string& source) {
  if (!j.is_object() || j.value("format", nlohmann::json()) != map_format_id)
    fail(source, std::string("not an error map (format must be ") + map_format_id + ")");
  if (!j.contains("travel_mm")) fail(source, "missing travel_mm");
  const std::array<Travel, 3> travel = fields::travel_mm(j["travel_mm"], source);
  const Vec3 tool = j.contains("tool_offset_mm") ? fields::vec_mm(j["tool_offset_mm"], source + ": tool_offset_mm")
                                                 : Vec3{};
  ErrorMap m = empty_map(travel, tool);
  m.machine = fields::text(j, "machine", source);
  const std::string chain = fields::text(j, "chain", source, "yxz");
  if (chain.size() != 3) fail(source, "chain must name the three axes from the bed up (e.g. yxz)");
  for (std::size_t k = 0; k < 3; ++k) {
    const auto a = chain[k] - 'x';
    if (a < 0 || a > 2) fail(source, "chain must name the three axes from the bed up (e.g. yxz)");
    m.chain[k] = a;
  }
  if (!j.contains("functions") || !j["functions"].is_array() || j["functions"].size() != 18)
    fail(source, "expected 18 functions");
  std::vector<std::pair<ErrorFunction*, std::vector<double>>> coefficients;
  std::array<std::array<bool, components>, 3> seen{};
  for (const auto& fj : j["functions"]) {
    const std::string name = fields::text(fj, "name", source + ": functions");
    int axis = -1, comp = -1;
    for (int a = 0; a < 3; ++a)
      for (int c = 0; c < components; ++c)
        if (function_name(a, c) == name) {
          axis = a;
          comp = c;
        }
    if (axis < 0) fail(source, "unknown function '" + name + "'");
    bool& once = seen[static_cast<std::size_t>(axis)][static_cast<std::size_t>(comp)];
    if (once) fail(source, "function '" + name + "' given twice");
    once = true;
    const std::string where = source + ": " + name;
    ErrorFunction& f = m.function(axis, comp);
    f.determined = fields::flag(fj, "determined", where);
    if (!f.determined) {
      f.why = fields::text(fj, "why", where);
      continue;
    }
    f.determined_by = fields::text(fj, "determined_by", where);
    f.orders = fields::integers(fj, "orders", where);
    const auto co = fields::numbers(fj, "coefficients", where);
    if (f.orders.empty() || co.size() != f.orders.size())
      fail(source, name + ": orders and coefficients must be given, one coefficient per order");
    for (std::size_t k = 0; k < f.orders.size(); ++k)
      if (f.orders[k] < lowest_order(axis, comp) || (k > 0 && f.orders[k] <= f.orders[k - 1]) || f.orders[k] > 40)
        fail(source, name + ": orders must ascend from " + std::to_string(lowest_order(axis, comp)));
    coefficients.emplace_back(&f, co);
  }
  if (!j.contains("squareness") || !j["squareness"].is_array() || j["squareness"].size() != 3)
    fail(source, "expected 3 squarenesses");
  std::array<double, 3> q{};
  std::array<bool, 3> seen_plane{};
  for (const auto& qj : j["squareness"]) {
    const int i = squareness_index(fields::text(qj, "plane", source + ": squareness"));
    if (i < 0) fail(source, "squareness of an unknown plane");
    if (seen_plane[static_cast<std::size_t>(i)]) fail(source, "a plane's squareness given twice");
    seen_plane[static_cast<std::size_t>(i)] = true;
    auto& sq = m.squareness[static_cast<std::size_t>(i)];
    const std::string where = source + ": squareness";
    sq.determined = fields::flag(qj, "determined", where);
    if (sq.determined) {
      q[static_cast<std::size_t>(i)] = fields::number(qj, "value_urad", where) * 1e-6;
      sq.determined_by = fields::text(qj, "determined_by", where);
    } else {
      sq.why = fields::text(qj, "why", where);
    }
  }
  assign_parameters(m);
  for (auto& [f, co] : coefficients)
    for (std::size_t k = 0; k < co.size(); ++k) f->coefficients[k] = co[k] * 1e-6;
  for (std::size_t i = 0; i < 3; ++i)
    if (m.squareness[i].determined) m.squareness[i].value_rad = q[i];
  if (j.contains("covariance") && j["covariance"].is_array() && !j["covariance"].empty()) {
    const auto& cov = j["covariance"];
    if (cov.size() != m.parameters) fail(source, "covariance must be parameters x parameters");
    m.covariance.assign(m.parameters * m.parameters, 0.0);
    for (std::size_t r = 0; r < m.parameters; ++r) {
      if (!cov[r].is_array() || cov[r].size() != m.parameters) fail(source, "covariance must be parameters x parameters");
      for (std::size_t c = 0; c < m.parameters; ++c) {
        if (!cov[r][c].is_number() || !std::isfinite(cov[r][c].get<double>()))
          fail(source, "covariance entries must be finite numbers");
        m.covariance[r * m.parameters + c] = cov[r][c].get<double>() * 1e-12;
      }
    }
  }
  return m;
}

nlohmann::json read_map_json(const std::string& path) {
  try {
    return nlohmann::json::parse(read_text_file(path));
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(path + ": not an error map (JSON: " + std::string(e.what()) + ")");
  }
}

ErrorMap read_map(const std::string& path) { return map_from_json(read_map_json(path), path); }

std::vector<AxisBacklash> backlash_from_json(const nlohmann::json& j, const std::string& source) {
  std::vector<AxisBacklash> out;
  if (!j.contains("backlash")) return out;
  if (!j["backlash"].is_array()) fail(source, "backlash must be a list");
  for (const auto& b : j["backlash"]) {
    const std::string a = fields::text(b, "axis", source + ": backlash");
    if (a.size() != 1 || a[0] < 'x' || a[0] > 'z') fail(source, "backlash of an unknown axis");
    out.push_back({a[0] - 'x', fields::number(b, "value_um", source) * 1e-6, fields::number(b, "u_um", source) * 1e-6,
                   fields::text(b, "from", source + ": backlash")});
  }
  return out;
}

}  // namespace guideway::models::map
