// The profilometer stream protocol (profile_stream.hpp): checksummed ASCII lines parsed into banners, headers, points
// and ends.
#include "drivers/profilometer/profile_stream.hpp"

#include <charconv>
#include <cmath>
#include <limits>

#include "core/sample.hpp"

namespace guideway::drivers::profilometer {

namespace {

std::vector<std::string_view> split_words(std::string_view s) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && s[i] == ' ') ++i;
    const std::size_t start = i;
    while (i < s.size() && s[i] != ' ') ++i;
    if (i > start) words.push_back(s.substr(start, i - start));
  }
  return words;
}

bool parse_u64(std::string_view s, std::uint64_t& out) {
  if (s.empty()) return false;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && p == s.data() + s.size();
}

bool parse_double(std::string_view s, double& out) {
  if (s.empty()) return false;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && p == s.data() + s.size() && std::isfinite(out);
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

std::string fixed(double v, int decimals) {
  char buf[64];
  const auto [p, ec] = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::fixed, decimals);
  return ec == std::errc() ? std::string(buf, p) : std::string("nan");
}

double unit_scale(std::string_view unit) {
  if (unit == "m") return 1.0;
  if (unit == "mm") return 1e-3;
  if (unit == "um") return 1e-6;
  if (unit == "nm") return 1e-9;
  return 0.0;
}

std::optional<ParsedLine> failed(std::string* error, std::string why) {
  if (error) *error = std::move(why);
  return std::nullopt;
}

}  // namespace

double ProfileHeader::x_scale() const noexcept { return unit_scale(x_unit); }
double ProfileHeader::z_scale() const noexcept { return unit_scale(z_unit); }

std::uint8_t line_checksum(std::string_view body) noexcept {
  std::uint8_t x = 0;
  for (char c : body) x = static_cast<std::uint8_t>(x ^ static_cast<std::uint8_t>(c));
  return x;
}

std::string frame_line(std::string_view body) {
  static constexpr char digits[] = "0123456789ABCDEF";
  const std::uint8_t c = line_checksum(body);
  std::string line(body);
  line += '*';
  line += digits[c >> 4];
  line += digits[c & 0xf];
  line += '\n';
  return line;
}

std::string format_banner(std::string_view instrument) {
  return frame_line("GWPROF " + std::to_string(stream_protocol_version) + " " + std::string(instrument));
}

std::string format_header(const ProfileHeader& h) {
  std::string body = "HDR id=" + std::to_string(h.id) + " points=" + std::to_string(h.points) +
                     " length_mm=" + fixed(h.length_m * 1e3, 6) + " spacing_um=" + fixed(h.spacing_m * 1e6, 4);
  if (!h.stylus.empty()) body += " stylus=" + h.stylus;
  if (h.tip_radius_m > 0) body += " tip_radius_um=" + fixed(h.tip_radius_m * 1e6, 3);
  if (h.z_range_m > 0) body += " z_range_um=" + fixed(h.z_range_m * 1e6, 1);
  if (h.speed_m_per_s > 0) body += " speed_mm_s=" + fixed(h.speed_m_per_s * 1e3, 4);
  body += " x_unit=" + h.x_unit + " z_unit=" + h.z_unit;
  return frame_line(body);
}

std::string format_point(std::uint64_t index, double x_m, double z_m, const ProfileHeader& h, bool over_range) {
  const double xs = h.x_scale() > 0 ? h.x_scale() : 1e-3;
  const double zs = h.z_scale() > 0 ? h.z_scale() : 1e-6;
  // 1 nm in x and 0.1 nm in z, whatever the units.
  const int x_dec = std::max(0, static_cast<int>(std::lround(std::log10(xs / 1e-9))));
  const int z_dec = std::max(0, static_cast<int>(std::lround(std::log10(zs / 1e-10))));
  return frame_line("P " + std::to_string(index) + " " + fixed(x_m / xs, x_dec) + " " +
                    (over_range || !std::isfinite(z_m) ? std::string("OVR") : fixed(z_m / zs, z_dec)));
}

std::string format_end(std::uint64_t id, std::uint64_t points) {
  return frame_line("END " + std::to_string(id) + " " + std::to_string(points));
}

std::string format_idle() { return frame_line("IDLE"); }

std::optional<ParsedLine> parse_line(std::string_view line, std::string* error) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  if (line.size() > max_line_bytes) return failed(error, "line too long");
  if (line.size() < 4 || line[line.size() - 3] != '*') return failed(error, "no *HH checksum");
  const int hi = hex_digit(line[line.size() - 2]);
  const int lo = hex_digit(line[line.size() - 1]);
  const std::string_view body = line.substr(0, line.size() - 3);
  if (hi < 0 || lo < 0) return failed(error, "checksum is not hexadecimal");
  if (line_checksum(body) != (hi << 4 | lo)) return failed(error, "checksum mismatch");
  const auto w = split_words(body);
  if (w.empty()) return failed(error, "empty record");
  ParsedLine r;
  if (w[0] == "P") {
    r.kind = LineKind::point;
    if (w.size() != 4) return failed(error, "P: expected index, x and z");
    if (!parse_u64(w[1], r.index)) return failed(error, "P: bad index");
    if (!parse_double(w[2], r.x)) return failed(error, "P: bad x");
    if (w[3] == "OVR") {
      r.over_range = true;
      r.z = std::numeric_limits<double>::quiet_NaN();
    } else if (!parse_double(w[3], r.z)) {
      return failed(error, "P: bad z");
    }
    return r;
  }
  if (w[0] == "HDR") {
    r.kind = LineKind::header;
    bool have_id = false, have_points = false, have_spacing = false;
    for (std::size_t i = 1; i < w.size(); ++i) {
      const auto eq = w[i].find('=');
      if (eq == std::string_view::npos || eq == 0) return failed(error, "HDR: expected key=value");
      const std::string_view key = w[i].substr(0, eq), value = w[i].substr(eq + 1);
      double d = 0;
      bool ok = true;
      if (key == "id") {
        ok = parse_u64(value, r.header.id);
        have_id = ok;
      } else if (key == "points") {
        ok = parse_u64(value, r.header.points) && r.header.points > 0;
        have_points = ok;
      } else if (key == "length_mm") {
        ok = parse_double(value, d) && d >= 0;
        r.header.length_m = d * 1e-3;
      } else if (key == "spacing_um") {
        ok = parse_double(value, d) && d > 0;
        r.header.spacing_m = d * 1e-6;
        have_spacing = ok;
      } else if (key == "tip_radius_um") {
        ok = parse_double(value, d) && d >= 0;
        r.header.tip_radius_m = d * 1e-6;
      } else if (key == "z_range_um") {
        ok = parse_double(value, d) && d >= 0;
        r.header.z_range_m = d * 1e-6;
      } else if (key == "speed_mm_s") {
        ok = parse_double(value, d) && d >= 0;
        r.header.speed_m_per_s = d * 1e-3;
      } else if (key == "stylus") {
        r.header.stylus = std::string(value);
      } else if (key == "x_unit") {
        r.header.x_unit = std::string(value);
        ok = r.header.x_scale() > 0 && value != "nm";
      } else if (key == "z_unit") {
        r.header.z_unit = std::string(value);
        ok = r.header.z_scale() > 0 && value != "m";
      }  // other keys: ignored (newer instruments may add some)
      if (!ok) return failed(error, "HDR: bad " + std::string(key));
    }
    if (!have_id || !have_points || !have_spacing) return failed(error, "HDR: id, points and spacing_um are required");
    return r;
  }
  if (w[0] == "END") {
    r.kind = LineKind::end;
    if (w.size() != 3 || !parse_u64(w[1], r.id) || !parse_u64(w[2], r.count)) {
      return failed(error, "END: expected id and points");
    }
    return r;
  }
  if (w[0] == "GWPROF") {
    r.kind = LineKind::banner;
    std::uint64_t v = 0;
    if (w.size() < 2 || !parse_u64(w[1], v)) return failed(error, "GWPROF: bad version");
    if (v != static_cast<std::uint64_t>(stream_protocol_version)) return failed(error, "GWPROF: unsupported version");
    r.version = static_cast<int>(v);
    for (std::size_t i = 2; i < w.size(); ++i) r.instrument += (i > 2 ? " " : "") + std::string(w[i]);
    return r;
  }
  if (w[0] == "IDLE") {
    if (w.size() != 1) return failed(error, "IDLE takes no arguments");
    r.kind = LineKind::idle;
    return r;
  }
  return failed(error, "unknown record \"" + std::string(w[0].substr(0, 16)) + "\"");
}

void ProfileAssembler::feed(std::string_view bytes, std::int64_t t_ns, std::vector<StreamEvent>& out) {
  for (char c : bytes) {
    if (c == '\n') {
      if (discarding_) {
        discarding_ = false;
        out.push_back({StreamEvent::Type::bad_line, 0, 0, 0, 0, 0, 0, "line too long"});
        if (header_) gap_ = true;
      } else {
        on_line(line_, t_ns, out);
      }
      line_.clear();
      continue;
    }
    if (discarding_) continue;
    if (line_.size() >= max_line_bytes + 1) {  // +1: a trailing '\r'
      discarding_ = true;
      line_.clear();
      continue;
    }
    line_.push_back(c);
  }
}

void ProfileAssembler::finish(std::vector<StreamEvent>& out) {
  release(out);
  line_.clear();
  discarding_ = false;
  gap_ = true;
}

void ProfileAssembler::release(std::vector<StreamEvent>& out) {
  if (held_) out.push_back(std::move(*held_));
  held_.reset();
}

void ProfileAssembler::on_line(std::string_view line, std::int64_t t_ns, std::vector<StreamEvent>& out) {
  if (line.empty() || line == "\r") return;  // blank lines are allowed
  std::string why;
  const std::optional<ParsedLine> p = parse_line(line, &why);
  auto bad = [&](std::string message) {
    out.push_back({StreamEvent::Type::bad_line, 0, 0, 0, 0, 0, 0, std::move(message)});
    if (header_) gap_ = true;  // inside a traverse a lost line may have been a point
  };
  if (!p) return bad(why);
  switch (p->kind) {
    case LineKind::banner:
      out.push_back({StreamEvent::Type::banner, 0, 0, 0, 0, 0, t_ns, p->instrument});
      return;
    case LineKind::idle:
      return;
    case LineKind::header:
      release(out);  // a previous traverse without END stays without an end mark: incomplete
      header_ = p->header;
      expected_index_ = 0;
      received_ = 0;
      next_start_ = true;
      out.push_back({StreamEvent::Type::header, p->header.id, 0, 0, 0, 0, t_ns, {}});
      return;
    case LineKind::end:
      if (!header_ || p->id != header_->id) return bad("END for a traverse that was not announced");
      if (held_) {  // the traverse is over; fewer points than the END counts make it partial
        held_->flags |= sample_profile_end | (received_ < p->count ? std::uint32_t{sample_partial} : 0u);
      }
      release(out);
      out.push_back({StreamEvent::Type::end, p->id, p->count, 0, 0, 0, t_ns, {}, p->count > received_ ? p->count - received_ : 0});
      header_.reset();
      return;
    case LineKind::point: {
      if (!header_) return bad("point outside a traverse");
      if (p->index >= header_->points) return bad("point index beyond the announced count");
      if (p->index < expected_index_) return bad("point index out of order");
      if (p->index > expected_index_) gap_ = true;
      release(out);
      StreamEvent e;
      e.type = StreamEvent::Type::point;
      e.profile_id = header_->id;
      e.index = p->index;
      e.x_m = p->x * header_->x_scale();
      e.z_m = p->over_range ? std::numeric_limits<double>::quiet_NaN() : p->z * header_->z_scale();
      e.flags = (p->over_range ? std::uint32_t{sample_out_of_range} : 0u) | (next_start_ ? sample_profile_start : 0u) |
                (gap_ ? std::uint32_t{sample_after_gap} : 0u);
      e.t_ns = t_ns;
      held_ = std::move(e);
      next_start_ = false;
      gap_ = false;
      expected_index_ = p->index + 1;
      ++received_;
      return;
    }
  }
}

}  // namespace guideway::drivers::profilometer
