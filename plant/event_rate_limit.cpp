// How many of a device's events go to the MQTT journal (event_rate_limit.hpp): a token bucket per source.
#include "plant/event_rate_limit.hpp"

#include <algorithm>

namespace guideway::plant {

EventRateLimit::EventRateLimit(double per_minute) : per_minute_(std::max(per_minute, 1e-3)) {}

void EventRateLimit::refill(Bucket& b, std::int64_t now_ns) const {
  if (now_ns > b.at_ns)
    b.tokens = std::min(per_minute_, b.tokens + static_cast<double>(now_ns - b.at_ns) * 1e-9 * per_minute_ / 60.0);
  b.at_ns = std::max(b.at_ns, now_ns);
}

bool EventRateLimit::admit(std::string_view source, std::int64_t now_ns) {
  auto it = buckets_.find(source);
  if (it == buckets_.end()) it = buckets_.emplace(std::string(source), Bucket{per_minute_, now_ns, 0}).first;
  Bucket& b = it->second;
  refill(b, now_ns);
  // A held-back count goes out before anything newer of the source, so the counted ones stay in order.
  if (b.tokens >= 1.0 && b.held_back == 0) {
    b.tokens -= 1.0;
    return true;
  }
  ++b.held_back;
  ++total_;
  return false;
}

std::vector<EventRateLimit::HeldBack> EventRateLimit::take_held_back(std::int64_t now_ns) {
  std::vector<HeldBack> out;
  for (auto& [source, b] : buckets_) {
    if (b.held_back == 0) continue;
    refill(b, now_ns);
    if (b.tokens < 1.0) continue;
    b.tokens -= 1.0;
    out.push_back({source, b.held_back});
    b.held_back = 0;
  }
  return out;
}

}  // namespace guideway::plant
