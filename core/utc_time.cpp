// UTC times and calendar dates as text (utc_time.hpp).
#include "core/utc_time.hpp"

#include <cmath>
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

std::optional<double> parse_utc_iso(std::string_view text) {
  // Fixed positions: YYYY-MM-DDTHH:MM:SS, then an optional fraction, then Z.
  const auto digits = [&](std::size_t at, std::size_t n, int& out) {
    if (at + n > text.size()) return false;
    out = 0;
    for (std::size_t i = at; i < at + n; ++i) {
      if (text[i] < '0' || text[i] > '9') return false;
      out = out * 10 + (text[i] - '0');
    }
    return true;
  };
  std::tm tm{};
  int year = 0, month = 0;
  if (!digits(0, 4, year) || text.size() < 20 || text[4] != '-' || !digits(5, 2, month) || text[7] != '-' ||
      !digits(8, 2, tm.tm_mday) || (text[10] != 'T' && text[10] != ' ') || !digits(11, 2, tm.tm_hour) ||
      text[13] != ':' || !digits(14, 2, tm.tm_min) || text[16] != ':' || !digits(17, 2, tm.tm_sec))
    return std::nullopt;
  if (month < 1 || month > 12 || tm.tm_mday < 1 || tm.tm_mday > 31 || tm.tm_hour > 23 || tm.tm_min > 59 ||
      tm.tm_sec > 60)
    return std::nullopt;
  double fraction = 0.0;
  std::size_t at = 19;
  if (text[at] == '.') {
    double scale = 0.1;
    ++at;
    if (at >= text.size() || text[at] < '0' || text[at] > '9') return std::nullopt;
    for (; at < text.size() && text[at] >= '0' && text[at] <= '9'; ++at, scale *= 0.1)
      fraction += (text[at] - '0') * scale;
  }
  if (at + 1 != text.size() || text[at] != 'Z') return std::nullopt;
  tm.tm_year = year - 1900;
  tm.tm_mon = month - 1;
  return static_cast<double>(timegm(&tm)) + fraction;
}

std::string utc_iso_ms(double seconds_since_epoch) {
  const double whole = std::floor(seconds_since_epoch);
  int ms = static_cast<int>(std::lround((seconds_since_epoch - whole) * 1000.0));
  auto seconds = static_cast<std::time_t>(whole);
  if (ms == 1000) {
    ms = 0;
    ++seconds;
  }
  char tail[16];
  std::snprintf(tail, sizeof tail, ".%03dZ", ms);
  return format_utc(seconds, "%Y-%m-%dT%H:%M:%S") + tail;
}

namespace {

// Days since 1970-01-01 of a proleptic Gregorian date (Howard Hinnant's days_from_civil).
long days_from_civil(int y, int m, int d) {
  y -= m <= 2 ? 1 : 0;
  const long era = (y >= 0 ? y : y - 399) / 400;
  const long yoe = y - era * 400;
  const long doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const long doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + doe - 719468;
}

int days_in_month(int year, int month) {
  static constexpr int days[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  const bool leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
  return month == 2 && leap ? 29 : days[month - 1];
}

}  // namespace

std::optional<CalendarDate> parse_iso_date(std::string_view text) {
  if (text.size() != 10 || text[4] != '-' || text[7] != '-') return std::nullopt;
  int v[3] = {0, 0, 0};
  const std::size_t at[3] = {0, 5, 8}, width[3] = {4, 2, 2};
  for (int k = 0; k < 3; ++k) {
    for (std::size_t i = at[k]; i < at[k] + width[k]; ++i) {
      if (text[i] < '0' || text[i] > '9') return std::nullopt;
      v[k] = v[k] * 10 + (text[i] - '0');
    }
  }
  const CalendarDate d{v[0], v[1], v[2]};
  if (d.year < 1 || d.month < 1 || d.month > 12 || d.day < 1 || d.day > days_in_month(d.year, d.month))
    return std::nullopt;
  return d;
}

std::string to_iso(const CalendarDate& date) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02d", date.year, date.month, date.day);
  return buf;
}

CalendarDate utc_date(double seconds_since_epoch) {
  const auto seconds = static_cast<std::time_t>(std::floor(seconds_since_epoch));
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  return {tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday};
}

CalendarDate utc_today() { return utc_date(static_cast<double>(std::time(nullptr))); }

long days_between(const CalendarDate& from, const CalendarDate& to) {
  return days_from_civil(to.year, to.month, to.day) - days_from_civil(from.year, from.month, from.day);
}

}  // namespace guideway
