#pragma once
// Numbers in text files: the fewest digits that read back (strtod) to the same double, so a file
// written by one tool and read by another loses nothing.

#include <charconv>
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

}  // namespace guideway
