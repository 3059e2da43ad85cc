#pragma once
// The wait before a driver's next connection attempt: the first wait after a working link is short
// (a device that comes straight back is found at once), each failure doubles it up to a ceiling (a
// device that stays away costs the loop one attempt per ceiling, not a busy retry).

#include <algorithm>
#include <chrono>
#include <cstdint>

namespace guideway::drivers {

class ReconnectBackoff {
 public:
  ReconnectBackoff() = default;
  ReconnectBackoff(std::chrono::milliseconds first, std::chrono::milliseconds ceiling)
      : first_(first), ceiling_(std::max(first, ceiling)), next_(first) {}

  // After a working link: the next wait is the first again.
  void reset() { next_ = first_; }

  // The wait before the next attempt; the one after it is twice as long (up to the ceiling).
  std::chrono::milliseconds take() {
    const std::chrono::milliseconds wait = next_;
    next_ = std::min(next_ * 2, ceiling_);
    return wait;
  }
  std::int64_t take_ns() { return std::chrono::nanoseconds(take()).count(); }

 private:
  std::chrono::milliseconds first_{0};
  std::chrono::milliseconds ceiling_{0};
  std::chrono::milliseconds next_{0};
};

}  // namespace guideway::drivers
