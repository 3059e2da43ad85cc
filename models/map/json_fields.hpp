#pragma once
// The members of the map's JSON files (the map file, the day's manifest) read with their type checked: a
// member of another type than the format's is refused with std::invalid_argument naming `where` (the file,
// and the part of it) and the member, never as the JSON library's type error. Absent optional members take
// their default.

#include <array>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "models/map/error_map.hpp"

namespace guideway::models::map::fields {

[[noreturn]] void fail(const std::string& where, const std::string& what);
// `j` itself must be an object (what `what` names: "the file", "test 3").
void require_object(const nlohmann::json& j, const std::string& where);
std::string text(const nlohmann::json& j, const char* key, const std::string& where, const std::string& absent = "");
bool flag(const nlohmann::json& j, const char* key, const std::string& where, bool absent = false);
// A finite number (required).
double number(const nlohmann::json& j, const char* key, const std::string& where);
std::vector<double> numbers(const nlohmann::json& j, const char* key, const std::string& where);
std::vector<int> integers(const nlohmann::json& j, const char* key, const std::string& where);
// [x, y, z] in mm, as metres.
Vec3 vec_mm(const nlohmann::json& j, const std::string& where);
// {"x": [lo, hi], "y": ..., "z": ...} in mm, lo < hi, as metres.
std::array<Travel, 3> travel_mm(const nlohmann::json& j, const std::string& where);

}  // namespace guideway::models::map::fields
