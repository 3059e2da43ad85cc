#pragma once
// Wall-clock (UTC) times as text, for file names, file headers, EVENTs and report subtitles. Sample
// times are CLOCK_MONOTONIC (core/mono_clock.hpp); these are for people and logs.

#include <string>

namespace guideway {

// Now, UTC, in a strftime format ("%Y%m%dT%H%M%SZ", "%Y-%m-%dT%H:%M:%SZ", ...).
[[nodiscard]] std::string utc_now(const char* strftime_format);
// Now, UTC, ISO 8601 to the second: 2026-11-25T17:04:05Z.
[[nodiscard]] inline std::string utc_now_iso() { return utc_now("%Y-%m-%dT%H:%M:%SZ"); }
// Now, UTC, ISO 8601 with milliseconds: 2026-11-25T17:04:05.123Z.
[[nodiscard]] std::string utc_now_iso_ms();

}  // namespace guideway
