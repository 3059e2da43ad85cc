// The micrometer-modbus driver as a loadable plugin (guidewayd finds it in its plugin directory).
#include "drivers/micrometer/micrometer_driver.hpp"

GUIDEWAY_DRIVER_PLUGIN(registry) { guideway::micrometer::register_micrometer_driver(registry); }
