#pragma once
// Unit factors used across the layers (SI inside; these convert at the boundaries).

#include <numbers>

namespace guideway {

inline constexpr double rad_per_arcsec = std::numbers::pi / (180.0 * 3600.0);

}  // namespace guideway
