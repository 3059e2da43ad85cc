#pragma once
// Wall-clock (UTC) times as text, for file names, file headers, EVENTs and report subtitles. Sample
// times are CLOCK_MONOTONIC (core/mono_clock.hpp); these are for people and logs.

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

}  // namespace guideway
