#pragma once
// A driver's samples taken from its ring as the pipeline would take them, for tests.

#include <chrono>
#include <cstddef>
#include <vector>

#include "core/sample.hpp"
#include "drivers/driver.hpp"
#include "test_support.hpp"

namespace guideway::test {

// Appends every sample waiting in the driver's ring to `samples`.
inline void drain_samples(drivers::Driver& driver, std::vector<Sample>& samples) {
  Sample s;
  while (driver.ring().try_pop(s)) samples.push_back(s);
}

// Drains until `samples` holds at least n, or the timeout passes; returns whether it does.
inline bool wait_samples(drivers::Driver& driver, std::vector<Sample>& samples, std::size_t n,
                         std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
  return eventually(
      [&] {
        drain_samples(driver, samples);
        return samples.size() >= n;
      },
      timeout);
}

}  // namespace guideway::test
