#pragma once
// How many of one device's events go to the MQTT journal (docs/plant.md): a token bucket per source,
// `per_minute` events a minute after a burst of as many. Those held back are counted per source, so the
// publisher can say how many in one `events_dropped` EVENT once the source's rate allows one more.
// Not thread safe (the publisher guards it).

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace guideway::plant {

class EventRateLimit {
 public:
  explicit EventRateLimit(double per_minute);

  // Whether an event of `source` at `now_ns` (monotonic) may go; when not, it is counted as held back.
  bool admit(std::string_view source, std::int64_t now_ns);

  struct HeldBack {
    std::string source;
    std::uint64_t count = 0;
  };
  // The sources with events held back whose rate allows one more event now: each takes that event's
  // token, and its count starts again from 0.
  std::vector<HeldBack> take_held_back(std::int64_t now_ns);

  [[nodiscard]] std::uint64_t held_back_total() const { return total_; }
  [[nodiscard]] double per_minute() const { return per_minute_; }

 private:
  struct Bucket {
    double tokens = 0;
    std::int64_t at_ns = 0;
    std::uint64_t held_back = 0;
  };
  void refill(Bucket& b, std::int64_t now_ns) const;

  double per_minute_;
  std::map<std::string, Bucket, std::less<>> buckets_;  // one per source: the configured devices
  std::uint64_t total_ = 0;
};

}  // namespace guideway::plant
