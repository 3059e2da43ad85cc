// Numbers as text (number_format.hpp): the shortest that reads back in files, rounded to its uncertainty for people.
#include "core/number_format.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

namespace guideway {

namespace {

// The decimal exponent printf's %e writes for v (correctly rounded to `digits` significant digits).
int printed_exponent(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*e", digits - 1, v);
  const char* e = std::strchr(buf, 'e');
  return e ? std::atoi(e + 1) : 0;
}

std::string non_finite(double v) { return std::isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf"); }

// v rounded to a multiple of 10^-decimals, decimals < 0 included ("12350" for 12345.6 at -1).
std::string at_decimal_place(double v, int decimals) {
  if (decimals < 0) {
    const double step = std::pow(10.0, -decimals);
    v = std::nearbyint(v / step) * step;
  }
  const int d = std::max(decimals, 0);
  std::string s(static_cast<std::size_t>(std::snprintf(nullptr, 0, "%.*f", d, v)) + 1, '\0');
  std::snprintf(s.data(), s.size(), "%.*f", d, v);
  s.pop_back();
  if (s.find_first_not_of("-0.") == std::string::npos && s.front() == '-') s.erase(0, 1);  // "-0.00" -> "0.00"
  return s;
}

}  // namespace

std::string format_fixed(double value, int decimals) {
  if (!std::isfinite(value)) return non_finite(value);
  return at_decimal_place(value, std::clamp(decimals, 0, 12));
}

std::string format_number(double value, int significant) {
  if (!std::isfinite(value) || value == 0) return format_fixed(value, 0);
  const double mag = std::floor(std::log10(std::abs(value)));
  if (mag >= -4 && mag < 9) return format_fixed(value, std::max(0, significant - 1 - static_cast<int>(mag)));
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", std::max(1, significant), value);
  return buf;
}

Rounded round_to_uncertainty(double value, double u, int significant) {
  if (!std::isfinite(value)) return {non_finite(value), {}, 0};
  if (!std::isfinite(u) || !(u > 0)) return {format_number(value, significant), {}, 0};
  // u to two significant digits as printf rounds it (exactly), then its exponent: 0.0996 -> 0.10.
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1e", u);
  const double u2 = std::strtod(buf, nullptr);
  const int u_exponent = std::atoi(std::strchr(buf, 'e') + 1);  // of the rounded u, as written (exact)
  const int decimals = 1 - u_exponent;
  const int magnitude = std::abs(value) > u2 ? printed_exponent(std::abs(value), 16) : u_exponent;
  if ((decimals <= 6 && magnitude < 6) || magnitude == 0)
    return {at_decimal_place(value, decimals), at_decimal_place(u2, decimals), 0};
  const double scale = std::pow(10.0, magnitude);
  return {at_decimal_place(value / scale, decimals + magnitude), at_decimal_place(u2 / scale, decimals + magnitude),
          magnitude};
}

std::string with_uncertainty(double value, double u, int significant) {
  const Rounded r = round_to_uncertainty(value, u, significant);
  if (r.u.empty()) return r.value;
  if (r.exponent == 0) return r.value + " \u00b1 " + r.u;
  return "(" + r.value + " \u00b1 " + r.u + ")e" + std::to_string(r.exponent);
}

}  // namespace guideway
