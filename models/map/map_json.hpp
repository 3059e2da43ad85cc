#pragma once
// The error map as a file (`guideway map fit --out MAP.json`, format guideway/map/1; docs/map.md "Files"):
// what `guideway map export`, `guideway compensate map` and `guideway report` read back. Coefficients,
// squarenesses and the covariance in um and urad; the fit's cross-checks, groups and notes and the
// volumetric accuracy ride along for people and reports. Throws std::invalid_argument naming the file for
// what it cannot read.

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "models/map/error_map.hpp"
#include "models/map/fit.hpp"
#include "models/map/volumetric.hpp"

namespace guideway::models::map {

inline constexpr const char* map_format_id = "guideway/map/1";

// ISO 230-1's names of the squarenesses (position-independent errors) and the sign that takes the map's
// (the virtual machine's [squareness]: the leaning axis leans towards + the other) to ISO's (a rotation
// about +z, +y, +x of the second axis' reference line): EC0Y = -xy, EB0Z = +xz, EA0Z = -yz.
[[nodiscard]] const char* iso_squareness_name(int index);
[[nodiscard]] double iso_squareness_sign(int index);

nlohmann::json to_json(const ErrorMap& map);
nlohmann::json to_json(const MapFit& fit, const std::optional<VolumetricAccuracy>& volumetric = {});
nlohmann::json to_json(const VolumetricAccuracy& v);
nlohmann::json to_json(const CrossCheck& c);

// The map of a map file's JSON (the fit's extras are ignored); `source` names it in errors.
ErrorMap map_from_json(const nlohmann::json& j, const std::string& source);
ErrorMap read_map(const std::string& path);
// The file's JSON as read (the map and the fit's extras), and the axes' backlash in it.
nlohmann::json read_map_json(const std::string& path);
std::vector<AxisBacklash> backlash_from_json(const nlohmann::json& j, const std::string& source);

}  // namespace guideway::models::map
