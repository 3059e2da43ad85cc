// The TA80-style autocollimator's ASCII protocol (autocollimator_protocol.hpp): requests built, replies parsed, pure.
#include "drivers/autocollimator/autocollimator_protocol.hpp"

#include <array>
#include <cmath>
#include <cstdio>

namespace guideway::drivers::autocollimator {

namespace {

int hex_value(char c) noexcept {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// [+-]d{1,4}.dd -> value; false on anything else.
bool parse_angle(std::string_view f, double& out) noexcept {
  if (f.size() < 5) return false;
  double sign = 1.0;
  std::size_t i = 0;
  if (f[0] == '+' || f[0] == '-') {
    sign = f[0] == '-' ? -1.0 : 1.0;
    i = 1;
  } else {
    return false;
  }
  const std::size_t dot = f.find('.');
  if (dot == std::string_view::npos || dot == i || dot - i > 4 || f.size() - dot != 3) return false;
  std::int64_t hundredths = 0;
  for (std::size_t k = i; k < f.size(); ++k) {
    if (k == dot) continue;
    if (f[k] < '0' || f[k] > '9') return false;
    hundredths = hundredths * 10 + (f[k] - '0');
  }
  out = sign * static_cast<double>(hundredths) / 100.0;
  return true;
}

bool parse_axis(std::string_view f, AxisState& state, double& value) noexcept {
  if (f == "OVER") {
    state = AxisState::out_of_range;
    return true;
  }
  if (f == "----") {
    state = AxisState::no_reflection;
    return true;
  }
  state = AxisState::valid;
  return parse_angle(f, value);
}

void format_axis(std::string& out, AxisState state, double v) {
  if (state == AxisState::no_reflection) {
    out += "----";
  } else if (state == AxisState::out_of_range) {
    out += "OVER";
  } else {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%+.2f", v);
    out += buf;
  }
}

}  // namespace

std::string format_request(Request request, int period_ms) {
  switch (request) {
    case Request::absolute:
      return "a\r";
    case Request::relative:
      return "r\r";
    case Request::set_zero:
      return "z\r";
    case Request::stream_start:
      return "c " + std::to_string(period_ms) + "\r";
    case Request::stream_stop:
      return "s\r";
  }
  return "\r";
}

std::string_view to_string(ParseError error) noexcept {
  switch (error) {
    case ParseError::none:
      return "ok";
    case ParseError::too_long:
      return "line too long";
    case ParseError::not_ascii:
      return "control or non-ASCII bytes";
    case ParseError::bad_checksum:
      return "wrong checksum";
    case ParseError::no_checksum:
      return "checksum missing";
    case ParseError::field_count:
      return "not four fields";
    case ParseError::bad_type:
      return "unknown reading type";
    case ParseError::bad_status:
      return "malformed status code";
    case ParseError::bad_value:
      return "malformed angle";
    case ParseError::inconsistent:
      return "status code disagrees with the values";
  }
  return "?";
}

std::string checksum_hex(std::string_view bytes) {
  unsigned x = 0;
  for (const char c : bytes) x ^= static_cast<unsigned char>(c);
  static constexpr char digits[] = "0123456789ABCDEF";
  return {digits[(x >> 4) & 0xF], digits[x & 0xF]};
}

ParseError parse_reply(std::string_view line, bool require_checksum, Reading& out) noexcept {
  if (line.size() > max_reply_length) return ParseError::too_long;
  for (const char c : line) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7E) return ParseError::not_ascii;
  }
  const std::size_t star = line.find('*');
  if (star != std::string_view::npos) {
    if (line.size() - star != 3) return ParseError::bad_checksum;
    const int hi = hex_value(line[star + 1]);
    const int lo = hex_value(line[star + 2]);
    if (hi < 0 || lo < 0) return ParseError::bad_checksum;
    unsigned x = 0;
    for (std::size_t i = 0; i < star; ++i) x ^= static_cast<unsigned char>(line[i]);
    if (static_cast<unsigned>(hi * 16 + lo) != (x & 0xFF)) return ParseError::bad_checksum;
    line = line.substr(0, star);
  } else if (require_checksum) {
    return ParseError::no_checksum;
  }
  std::array<std::string_view, 4> f;
  std::size_t n = 0;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && line[i] == ' ') ++i;
    if (i >= line.size()) break;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ') ++i;
    if (n == f.size()) return ParseError::field_count;
    f[n++] = line.substr(start, i - start);
  }
  if (n != 4) return ParseError::field_count;
  Reading r;
  if (f[0] == "4") {
    r.relative = false;
  } else if (f[0] == "2") {
    r.relative = true;
  } else {
    return ParseError::bad_type;
  }
  if (f[1].size() != 3) return ParseError::bad_status;
  for (const char c : f[1]) {
    if (c < '0' || c > '9') return ParseError::bad_status;
  }
  const int kind = f[1][0] - '0';
  const int range = f[1][1] - '0';
  const int valid = f[1][2] - '0';
  if (kind > 1 || range > 1 || valid > 3) return ParseError::bad_status;
  if (!parse_axis(f[2], r.x_state, r.x_arcsec) || !parse_axis(f[3], r.y_state, r.y_arcsec)) {
    return ParseError::bad_value;
  }
  const bool any_over = r.x_state == AxisState::out_of_range || r.y_state == AxisState::out_of_range;
  const bool x_reflect = r.x_state != AxisState::no_reflection;
  const bool y_reflect = r.y_state != AxisState::no_reflection;
  if ((kind == 1) != r.relative || (range == 1) != any_over || ((valid & 1) != 0) != x_reflect ||
      ((valid & 2) != 0) != y_reflect) {
    return ParseError::inconsistent;
  }
  out = r;
  return ParseError::none;
}

std::string format_reply(const Reading& reading, double range_arcsec, bool with_checksum) {
  Reading r = reading;
  auto clamp_state = [&](AxisState& s, double& v) {
    v = std::round(v * 100.0) / 100.0;
    if (s == AxisState::valid && (!(std::fabs(v) <= range_arcsec) || std::fabs(v) > max_reported_arcsec)) {
      s = AxisState::out_of_range;
    }
  };
  clamp_state(r.x_state, r.x_arcsec);
  clamp_state(r.y_state, r.y_arcsec);
  const bool any_over = r.x_state == AxisState::out_of_range || r.y_state == AxisState::out_of_range;
  const int valid = (r.x_state != AxisState::no_reflection ? 1 : 0) | (r.y_state != AxisState::no_reflection ? 2 : 0);
  std::string out = r.relative ? "2 1" : "4 0";
  out += any_over ? '1' : '0';
  out += static_cast<char>('0' + valid);
  out += ' ';
  format_axis(out, r.x_state, r.x_arcsec);
  out += ' ';
  format_axis(out, r.y_state, r.y_arcsec);
  if (with_checksum) out += "*" + checksum_hex(out);
  return out;
}

}  // namespace guideway::drivers::autocollimator
