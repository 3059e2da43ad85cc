#pragma once
// Numbers as text. In files: the fewest digits that read back (strtod) to the same double, so a file
// written by one tool and read by another loses nothing. In messages, tables and reports: as many as a
// reader needs (a printf format, significant digits, or a measured value rounded to its uncertainty).
// The one place numbers are rounded for people: results/parameters.hpp's shown() adds the unit and the
// label. Pure; thread safe.

#include <charconv>
#include <cstdio>
#include <string>
#include <string_view>

namespace guideway {

inline void append_shortest(std::string& out, double v) {
  char buf[32];  // the longest shortest form is 24 characters ("-2.2250738585072014e-308")
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, r.ptr);
}

[[nodiscard]] inline std::string shortest(double v) {
  std::string out;
  append_shortest(out, v);
  return out;
}

// One number in a printf conversion ("%.3f", "%+.2g um", ...), for messages and tables.
[[nodiscard]] inline std::string printf_number(const char* printf_format, double v) {
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
  // Sized to the text: "%.3f" of 1e300 is over 300 characters, and none may be cut.
  std::string s(static_cast<std::size_t>(std::snprintf(nullptr, 0, printf_format, v)) + 1, '\0');
  std::snprintf(s.data(), s.size(), printf_format, v);
#pragma GCC diagnostic pop
  s.pop_back();
  return s;
}

// `digits` significant digits, as printf's %g (and an ostream's default notation) writes them.
[[nodiscard]] inline std::string significant_digits(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

// A number with `decimals` digits after the point (0..12); "-0.00" is printed as "0.00".
[[nodiscard]] std::string format_fixed(double value, int decimals);
// A number with about `significant` digits, without exponent for everyday magnitudes (1e-4 .. 1e9).
[[nodiscard]] std::string format_number(double value, int significant = 4);

// A measured value and its standard uncertainty, rounded as the GUM (7.2.6) asks: u to two significant
// digits (to the nearest), the value to the same decimal place. Where that place is more than 6
// decimals after the point, or the larger of |value| and u is 1e6 or more, both share a power of ten
// (unless it is 10^0): value "2.211", u "0.013", exponent -7 for (2.211 ± 0.013)e-7. Without a positive finite u the
// value has `significant` digits (format_number) and u is empty. tests/core/number_rounding_test.py holds this rule
// against an independent implementation (Python's decimal).
struct Rounded {
  std::string value;
  std::string u;
  int exponent = 0;  // 0: none
};
[[nodiscard]] Rounded round_to_uncertainty(double value, double u, int significant = 4);
// The same as one text: "-10.01 ± 0.34", "(2.211 ± 0.013)e-7"; without u the value alone.
[[nodiscard]] std::string with_uncertainty(double value, double u, int significant = 4);

}  // namespace guideway
