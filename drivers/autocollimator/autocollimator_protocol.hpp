#pragma once
// The TA80-style autocollimator's ASCII protocol, modelled on ELCOMAT-style instruments: one-letter
// requests ("a" absolute reading, "r" relative reading, "z" set the relative zero, "c <ms>" start
// continuous output, "s" stop it) ending in CR; replies "T SSS X Y" ending in CR, optionally followed
// by "*HH" (XOR checksum of the bytes before '*'). T is the reading type (4 absolute, 2 relative),
// SSS a status code (hundreds: 0 absolute/1 relative; tens: 1 = an axis out of range; units: bit 0 X,
// bit 1 Y has a reflection), X and Y are arc-seconds with two decimals ("+123.45"), "OVER" for a
// reflection outside the range, "----" for none. See docs/protocols.md. Pure functions, thread safe.

#include <cstdint>
#include <string>
#include <string_view>

namespace guideway::drivers::autocollimator {

enum class Request { absolute, relative, set_zero, stream_start, stream_stop };
// The request line including its CR; period_ms only for stream_start.
std::string format_request(Request request, int period_ms = 0);

// What the instrument reports on one axis.
enum class AxisState { valid, out_of_range, no_reflection };

struct Reading {
  bool relative = false;
  AxisState x_state = AxisState::valid;
  AxisState y_state = AxisState::valid;
  double x_arcsec = 0.0;  // meaningful only when the axis is valid
  double y_arcsec = 0.0;
};

enum class ParseError {
  none,
  too_long,
  not_ascii,     // control or non-ASCII bytes
  bad_checksum,  // "*HH" present and wrong, or malformed
  no_checksum,   // checksum required but absent
  field_count,   // not four fields
  bad_type,      // first field not 4 or 2
  bad_status,    // not three digits, or digits out of range
  bad_value,     // an angle field that is neither a number with two decimals, OVER nor ----
  inconsistent,  // status code disagrees with the type or the value fields
};
std::string_view to_string(ParseError error) noexcept;

inline constexpr std::size_t max_reply_length = 64;
inline constexpr double max_reported_arcsec = 9999.99;

// Parses one reply line (without its line terminator).
ParseError parse_reply(std::string_view line, bool require_checksum, Reading& out) noexcept;

// The reply line for a reading (without terminator). Values are rounded to 0.01"; an axis whose
// value exceeds range_arcsec in magnitude is reported as OVER.
std::string format_reply(const Reading& reading, double range_arcsec, bool with_checksum);

// XOR of the bytes, as two upper-case hex digits.
std::string checksum_hex(std::string_view bytes);

}  // namespace guideway::drivers::autocollimator
