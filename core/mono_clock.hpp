#pragma once
// CLOCK_MONOTONIC in nanoseconds: the one time base for ordering and latency.

#include <cstdint>
#include <ctime>

namespace guideway {

inline std::int64_t mono_now_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace guideway
