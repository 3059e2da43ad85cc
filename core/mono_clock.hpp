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

// CLOCK_REALTIME minus CLOCK_MONOTONIC now, in nanoseconds: subtract it from a CLOCK_REALTIME time
// (e.g. a kernel receive timestamp, SO_TIMESTAMPNS) to put it on the monotonic clock. Sampled again
// at each use, so a step of the real-time clock (settimeofday, an NTP step) only mis-converts times
// taken before the step and converted after it, by the size of the step.
inline std::int64_t realtime_minus_mono_ns() noexcept {
  timespec mono{}, real{};
  clock_gettime(CLOCK_MONOTONIC, &mono);
  clock_gettime(CLOCK_REALTIME, &real);
  return (static_cast<std::int64_t>(real.tv_sec) - mono.tv_sec) * 1'000'000'000 + (real.tv_nsec - mono.tv_nsec);
}

}  // namespace guideway
