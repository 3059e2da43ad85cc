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
// Reads monotonic, real-time, monotonic and pairs the real-time reading with the midpoint of the two
// monotonic ones; a preemption between the readings would shift the offset by up to its length, so
// when they are more than 10 us apart it tries again (4 times at most) and keeps the tightest.
inline std::int64_t realtime_minus_mono_ns() noexcept {
  constexpr std::int64_t good_enough_ns = 10'000;
  std::int64_t best_offset = 0;
  std::int64_t best_width = INT64_MAX;
  for (int attempt = 0; attempt < 4 && best_width > good_enough_ns; ++attempt) {
    timespec real{};
    const std::int64_t mono_before = mono_now_ns();
    clock_gettime(CLOCK_REALTIME, &real);
    const std::int64_t mono_after = mono_now_ns();
    const std::int64_t width = mono_after - mono_before;
    if (width < best_width) {
      best_width = width;
      best_offset = static_cast<std::int64_t>(real.tv_sec) * 1'000'000'000 + real.tv_nsec -
                    (mono_before + width / 2);
    }
  }
  return best_offset;
}

}  // namespace guideway
