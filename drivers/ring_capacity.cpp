// The ring-size rule (ring_capacity.hpp), and a device's ring as its configuration and the rule give it.
#include "drivers/ring_capacity.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/number_format.hpp"
#include "drivers/driver.hpp"

namespace guideway::drivers {

std::size_t ring_capacity_for(double full_rate_hz) {
  if (!(full_rate_hz > 0) || !std::isfinite(full_rate_hz))
    throw std::invalid_argument("a device's full rate must be a positive number of Hz");
  const double held = std::ceil(ring_hold_s * full_rate_hz);
  if (held >= static_cast<double>(max_ring_capacity)) return max_ring_capacity;
  return std::bit_ceil(std::max(min_ring_capacity, static_cast<std::size_t>(held)));
}

std::size_t DeviceConfig::ring_for(double full_rate_hz) const {
  const std::size_t rule = ring_capacity_for(full_rate_hz);
  if (!ring_capacity) return rule;
  if (*ring_capacity < rule) {
    std::string why = "ring_capacity = " + std::to_string(*ring_capacity) +
                      (table.has("ring_capacity") ? "" : " ([daemon]'s, which this device takes)") + " holds ";
    append_shortest(why, std::round(static_cast<double>(*ring_capacity) / full_rate_hz * 10) / 10);
    why += " s of device " + name + "'s full rate (";
    append_shortest(why, full_rate_hz);
    why += " Hz); a ring holds at least ";
    append_shortest(why, ring_hold_s);
    why += " s of it (docs/configuration.md, ring_capacity): give at least " + std::to_string(rule) +
           ", or leave ring_capacity out for that";
    table.fail("ring_capacity", why);
  }
  return *ring_capacity;
}

}  // namespace guideway::drivers
