#pragma once
// Numbers as text. In files: the fewest digits that read back (strtod) to the same double, so a file
// written by one tool and read by another loses nothing. In messages and tables: as many as a reader
// needs (a printf format, or significant digits).

#include <charconv>
#include <cstdio>
#include <string>

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

}  // namespace guideway
