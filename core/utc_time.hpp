#pragma once
// Wall-clock (UTC) times as text, for file names, file headers, EVENTs and report subtitles. Sample
// times are CLOCK_MONOTONIC (core/mono_clock.hpp); these are for people and logs.

#include <compare>
#include <optional>
#include <string>
#include <string_view>

namespace guideway {

// Now, UTC, in a strftime format ("%Y%m%dT%H%M%SZ", "%Y-%m-%dT%H:%M:%SZ", ...).
[[nodiscard]] std::string utc_now(const char* strftime_format);
// Now, UTC, ISO 8601 to the second: 2026-11-25T17:04:05Z.
[[nodiscard]] inline std::string utc_now_iso() { return utc_now("%Y-%m-%dT%H:%M:%SZ"); }
// Now, UTC, ISO 8601 with milliseconds: 2026-11-25T17:04:05.123Z.
[[nodiscard]] std::string utc_now_iso_ms();

// Seconds since the epoch of an ISO 8601 UTC time, YYYY-MM-DDTHH:MM:SS[.fraction]Z (a space for the T
// is accepted); nullopt when `text` is not one.
[[nodiscard]] std::optional<double> parse_utc_iso(std::string_view text);
// Seconds since the epoch as ISO 8601 UTC with milliseconds (2026-11-25T17:04:05.123Z): the form that
// sorts as text in time order.
[[nodiscard]] std::string utc_iso_ms(double seconds_since_epoch);

// A calendar date without a time of day (a calibration certificate's dates), compared in time order.
struct CalendarDate {
  int year = 1970;
  int month = 1;  // 1..12
  int day = 1;    // 1..31, valid for the month
  auto operator<=>(const CalendarDate&) const = default;
};
// YYYY-MM-DD (ISO 8601's extended calendar date) of a date that exists (2025-02-29 does not); nullopt
// for anything else.
[[nodiscard]] std::optional<CalendarDate> parse_iso_date(std::string_view text);
[[nodiscard]] std::string to_iso(const CalendarDate& date);
// The UTC date of a time in seconds since the epoch; today's UTC date.
[[nodiscard]] CalendarDate utc_date(double seconds_since_epoch);
[[nodiscard]] CalendarDate utc_today();
// Whole days from `from` to `to` (negative when `to` is earlier).
[[nodiscard]] long days_between(const CalendarDate& from, const CalendarDate& to);

}  // namespace guideway
