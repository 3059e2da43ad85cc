#include "core/utc_time.hpp"

#include <cstdio>
#include <ctime>

namespace guideway {

namespace {

std::string format_utc(std::time_t seconds, const char* strftime_format) {
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char buf[64];
  const std::size_t n = std::strftime(buf, sizeof buf, strftime_format, &tm);
  return std::string(buf, n);
}

}  // namespace

std::string utc_now(const char* strftime_format) { return format_utc(std::time(nullptr), strftime_format); }

std::string utc_now_iso_ms() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  char ms[16];
  std::snprintf(ms, sizeof ms, ".%03dZ", static_cast<int>(ts.tv_nsec / 1'000'000));
  return format_utc(ts.tv_sec, "%Y-%m-%dT%H:%M:%S") + ms;
}

}  // namespace guideway
