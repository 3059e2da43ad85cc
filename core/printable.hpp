#pragma once
// Text from outside (a broker's payload, a device's reply) made safe to print on a terminal or in a
// log: control characters (C0, DEL, C1) and bytes that are not UTF-8 become visible escapes (\x1b,
// \u009b), so that no escape sequence from a message reaches the reader's terminal. The one function
// for it; HTML has report/html.hpp's html_escape. Pure; thread safe.

#include <string>
#include <string_view>

namespace guideway {

[[nodiscard]] std::string printable(std::string_view text);

// The length of the well-formed UTF-8 sequence that starts at text[at] (1 for ASCII, 2..4), or 0 when
// there is none there (a stray continuation byte, an overlong form, a surrogate, past U+10FFFF).
[[nodiscard]] std::size_t utf8_sequence_length(std::string_view text, std::size_t at);

// The columns text takes on a terminal: one per character (a UTF-8 sequence, "µ" or "±", is one; a byte
// that is not UTF-8 counts as one), so tables of values with units line up.
[[nodiscard]] std::size_t display_width(std::string_view text);

}  // namespace guideway
