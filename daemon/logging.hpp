#pragma once
// Logger for guidewayd: to the journal when systemd started us (JOURNAL_STREAM names our stderr),
// to the terminal otherwise.

#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include <spdlog/spdlog.h>

namespace guideway::daemon {

std::shared_ptr<spdlog::logger> make_logger(const std::string& level);
bool stderr_is_journal();

// One log line per reason per period: a reason that repeats (a client loop that connects and resets)
// is logged when first seen, then counted, and the count goes with the next line logged for it once
// the period has passed. Not thread safe (the event loop's).
class RepeatLimiter {
 public:
  explicit RepeatLimiter(std::int64_t period_ns = 60'000'000'000) : period_ns_(period_ns) {}
  // Whether to log `reason` now; `suppressed` = how many were not logged since the last line.
  bool allow(const std::string& reason, std::int64_t now_ns, std::uint64_t& suppressed);

 private:
  struct Seen {
    std::int64_t logged_ns = 0;
    std::uint64_t suppressed = 0;
  };
  std::int64_t period_ns_;
  std::map<std::string, Seen> seen_;
};

}  // namespace guideway::daemon
