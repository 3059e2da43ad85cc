// The autocollimator-serial driver as a loadable plugin (guidewayd finds it in lib/guideway/plugins).
#include "drivers/autocollimator/autocollimator_driver.hpp"

GUIDEWAY_DRIVER_PLUGIN(registry) { guideway::autocollimator::register_autocollimator_driver(registry); }
