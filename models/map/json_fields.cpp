// The members of the map's JSON files read with their type checked (json_fields.hpp), a wrong one refused by name.
#include "models/map/json_fields.hpp"

#include <cmath>
#include <stdexcept>

namespace guideway::models::map::fields {

void fail(const std::string& where, const std::string& what) { throw std::invalid_argument(where + ": " + what); }

void require_object(const nlohmann::json& j, const std::string& where) {
  if (!j.is_object()) fail(where, "expected an object {...}, not " + std::string(j.type_name()));
}

std::string text(const nlohmann::json& j, const char* key, const std::string& where, const std::string& absent) {
  require_object(j, where);
  const auto it = j.find(key);
  if (it == j.end()) return absent;
  if (!it->is_string()) fail(where, std::string("'") + key + "' must be text, not " + it->type_name());
  return it->get<std::string>();
}

bool flag(const nlohmann::json& j, const char* key, const std::string& where, bool absent) {
  require_object(j, where);
  const auto it = j.find(key);
  if (it == j.end()) return absent;
  if (!it->is_boolean()) fail(where, std::string("'") + key + "' must be true or false, not " + it->type_name());
  return it->get<bool>();
}

namespace {

double finite(const nlohmann::json& v, const std::string& where, const std::string& what) {
  if (!v.is_number()) fail(where, what + " must be a number, not " + v.type_name());
  const double x = v.get<double>();
  if (!std::isfinite(x)) fail(where, what + " is not finite");
  return x;
}

}  // namespace

double number(const nlohmann::json& j, const char* key, const std::string& where) {
  require_object(j, where);
  const auto it = j.find(key);
  if (it == j.end()) fail(where, std::string("missing number '") + key + "'");
  return finite(*it, where, std::string("'") + key + "'");
}

std::vector<double> numbers(const nlohmann::json& j, const char* key, const std::string& where) {
  require_object(j, where);
  std::vector<double> out;
  const auto it = j.find(key);
  if (it == j.end()) return out;
  if (!it->is_array()) fail(where, std::string("'") + key + "' must be a list of numbers");
  for (const auto& v : *it) out.push_back(finite(v, where, std::string("'") + key + "' item"));
  return out;
}

std::vector<int> integers(const nlohmann::json& j, const char* key, const std::string& where) {
  require_object(j, where);
  std::vector<int> out;
  const auto it = j.find(key);
  if (it == j.end()) return out;
  if (!it->is_array()) fail(where, std::string("'") + key + "' must be a list of integers");
  for (const auto& v : *it) {
    if (!v.is_number_integer() || std::abs(v.get<double>()) > 1e6)
      fail(where, std::string("'") + key + "' must be a list of integers");
    out.push_back(v.get<int>());
  }
  return out;
}

Vec3 vec_mm(const nlohmann::json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 3) fail(where, "expected [x, y, z] in mm");
  Vec3 v{};
  for (std::size_t i = 0; i < 3; ++i) v[i] = finite(j[i], where, "each of [x, y, z]") * 1e-3;
  return v;
}

std::array<Travel, 3> travel_mm(const nlohmann::json& j, const std::string& where) {
  if (!j.is_object()) fail(where, "travel_mm must be {\"x\": [lo, hi], \"y\": [lo, hi], \"z\": [lo, hi]}");
  std::array<Travel, 3> t{};
  for (int a = 0; a < 3; ++a) {
    const std::string name = axis_name(a);
    const auto it = j.find(name);
    if (it == j.end() || !it->is_array() || it->size() != 2 || !(*it)[0].is_number() || !(*it)[1].is_number() ||
        !((*it)[1].get<double>() > (*it)[0].get<double>()) || !std::isfinite((*it)[0].get<double>()) ||
        !std::isfinite((*it)[1].get<double>()))
      fail(where, "travel_mm." + name + " must be [lo, hi] with lo < hi");
    t[static_cast<std::size_t>(a)] = {(*it)[0].get<double>() * 1e-3, (*it)[1].get<double>() * 1e-3};
  }
  return t;
}

}  // namespace guideway::models::map::fields
