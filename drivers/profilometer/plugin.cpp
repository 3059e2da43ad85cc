// The profilometer-tcp driver as a loadable plugin (guidewayd finds it in its plugin directory).
#include "drivers/profilometer/profilometer_driver.hpp"

GUIDEWAY_DRIVER_PLUGIN(registry) { guideway::profilometer::register_profilometer_driver(registry); }
