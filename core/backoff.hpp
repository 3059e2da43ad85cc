#pragma once
// The wait before the next retry of something that failed (a device's connection, a broker
// connection, an emulator's restart): `min_s` first, doubling per failure up to `max_s` (a ceiling
// below `min_s` is `min_s`), back to `min_s` after a success. A retry that keeps failing costs one
// attempt per ceiling, not a busy loop; one that comes straight back is found at once.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>

namespace guideway {

struct Backoff {
  double min_s = 1.0;
  double max_s = 60.0;
  double next_s = min_s;

  // From waits given as durations (a driver's `reconnect_min_ms` / `reconnect_max_ms`).
  static Backoff between(std::chrono::nanoseconds first, std::chrono::nanoseconds ceiling) noexcept {
    const double first_s = std::chrono::duration<double>(first).count();
    return Backoff{first_s, std::chrono::duration<double>(ceiling).count(), first_s};
  }

  // The wait before this retry (s); the one after it doubles.
  double take_s() noexcept {
    const double wait_s = next_s;
    next_s = std::min(std::max(max_s, min_s), 2 * next_s);
    return wait_s;
  }
  // take_s() in nanoseconds (deadlines on CLOCK_MONOTONIC).
  std::int64_t take_ns() noexcept { return std::llround(take_s() * 1e9); }
  void reset() noexcept { next_s = min_s; }
};

}  // namespace guideway
