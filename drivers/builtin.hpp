#pragma once
// The drivers compiled into guidewayd (plugins add more at run time).

#include "drivers/driver.hpp"

namespace guideway::drivers {

void register_builtin_drivers(DriverRegistry& registry);

}  // namespace guideway::drivers
