// The instrument drivers compiled into guidewayd, registered by name (builtin.hpp); plugins add more at run time.
#include "drivers/builtin.hpp"

#include "drivers/autocollimator/autocollimator_driver.hpp"
#include "drivers/dbb/dbb_driver.hpp"
#include "drivers/linuxcnc/linuxcnc_driver.hpp"
#include "drivers/micrometer/micrometer_driver.hpp"
#include "drivers/profilometer/profilometer_driver.hpp"

namespace guideway::drivers {

namespace {

// One line per instrument (its folder under drivers/ holds the rest), as chrony's refclock table.
constexpr void (*builtin_drivers[])(DriverRegistry&) = {
    &dbb::register_dbb_driver,
    &autocollimator::register_autocollimator_driver,
    &micrometer::register_micrometer_driver,
    &profilometer::register_profilometer_driver,
    &linuxcnc::register_linuxcnc_driver,
};

}  // namespace

void register_builtin_drivers(DriverRegistry& registry) {
  for (const auto register_driver : builtin_drivers) register_driver(registry);
}

}  // namespace guideway::drivers
