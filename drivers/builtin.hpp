#pragma once
// The instrument drivers compiled into guidewayd: dbb-can, autocollimator-serial, micrometer-modbus,
// profilometer-tcp. Plugins in plugin_dir add more at run time (a plugin may replace one by name).

#include "drivers/driver.hpp"

namespace guideway::drivers {

void register_builtin_drivers(DriverRegistry& registry);

}  // namespace guideway::drivers
