// The dbb-can driver as a loadable plugin (guidewayd finds it in lib/guideway/plugins).
#include "drivers/dbb/dbb_driver.hpp"

GUIDEWAY_DRIVER_PLUGIN(registry) { guideway::dbb::register_dbb_driver(registry); }
