#pragma once
// The wait before the next retry of something that failed (a broker connection, an emulator's
// restart): `min_s` first, doubling per failure up to `max_s`, back to `min_s` after a success.

#include <algorithm>

namespace guideway {

struct Backoff {
  double min_s = 1.0;
  double max_s = 60.0;
  double next_s = min_s;

  // The wait before this retry; the one after it doubles.
  double take() noexcept {
    const double wait_s = next_s;
    next_s = std::min(max_s, 2 * next_s);
    return wait_s;
  }
  void reset() noexcept { next_s = min_s; }
};

}  // namespace guideway
