#pragma once
// A driver's own counters (DriverStatus::driver_counters, STATUS "driver_counters") by name, for tests.

#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <string>

#include "drivers/driver.hpp"

namespace guideway::test {

inline std::map<std::string, std::uint64_t> driver_counters_by_name(const drivers::DriverStatus& status) {
  std::map<std::string, std::uint64_t> by_name;
  for (const auto& c : status.driver_counters) {
    if (!by_name.emplace(c.name, c.value).second) ADD_FAILURE() << "driver counter " << c.name << " listed twice";
  }
  return by_name;
}

}  // namespace guideway::test
