// A ballbar test as the G-code a controller runs (dbb_program.hpp): each circle's feed-in, data and feed-out arcs.
#include "formats/dbb_program.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace guideway::formats {

namespace {

constexpr double deg = std::numbers::pi / 180.0;
constexpr double mm_per_inch = 25.4;

struct PlaneCode {
  int a, b;          // the plane's axes (0 = x, 1 = y, 2 = z)
  const char* code;  // G17, G18, G19
  bool ccw_is_g3;    // G18 turns about +Y, the runs' xz about -Y
};

PlaneCode plane_code(const std::string& plane) {
  if (plane == "xy") return {0, 1, "G17", true};
  if (plane == "xz") return {0, 2, "G18", false};
  if (plane == "yz") return {1, 2, "G19", true};
  throw std::invalid_argument("plane \"" + plane + "\": xy, xz or yz");
}

void check(const DbbProgram& p) {
  if (!(p.feed_mm_per_min > 0) || !std::isfinite(p.feed_mm_per_min))
    throw std::invalid_argument("the feed must be a number > 0 mm/min");
  if (!(p.pause_s >= 0) || !std::isfinite(p.pause_s)) throw std::invalid_argument("the pause must be >= 0 s");
  if (p.session_pin > 63) throw std::invalid_argument("the session pin must be motion.digital-out-00 to -63");
  for (const double c : p.center_mm)
    if (!std::isfinite(c)) throw std::invalid_argument("the centre must be finite");
  if (p.circles.empty()) throw std::invalid_argument("a test program needs a circle");
  for (const auto& c : p.circles) {
    plane_code(c.plane);
    if (!(c.radius_mm > 0) || !std::isfinite(c.radius_mm)) throw std::invalid_argument("a radius must be > 0 mm");
    if (!(c.data_arc_deg >= 180 && c.data_arc_deg <= 360))
      throw std::invalid_argument("a data arc must be 180 to 360 deg (a DBB run needs at least 180 deg)");
    if (!(c.overshoot_deg >= 0 && c.overshoot_deg <= 90))
      throw std::invalid_argument("a feed-in/feed-out arc must be 0 to 90 deg");
    if (!std::isfinite(c.start_deg)) throw std::invalid_argument("a start angle must be finite");
  }
}

class Writer {
 public:
  explicit Writer(const DbbProgram& p) : p_(p), scale_(p.inch ? 1.0 / mm_per_inch : 1.0) {}

  std::string text() const { return out_.str(); }
  void line(const std::string& s) { out_ << s << "\n"; }
  // A length in the program's units.
  std::string len(double mm) const {
    char b[48];
    std::snprintf(b, sizeof(b), p_.inch ? "%.7f" : "%.6f", mm * scale_);
    std::string s(b);
    if (s == "-0.000000" || s == "-0.0000000") s.erase(0, 1);
    return s;
  }
  // Machine coordinates (mm) of the circle's point at angle theta.
  std::array<double, 3> point(const DbbProgramCircle& c, const PlaneCode& pc, double theta_deg) const {
    std::array<double, 3> q = p_.center_mm;
    q[static_cast<std::size_t>(pc.a)] += c.radius_mm * std::cos(theta_deg * deg);
    q[static_cast<std::size_t>(pc.b)] += c.radius_mm * std::sin(theta_deg * deg);
    return q;
  }
  std::string xyz(const std::array<double, 3>& q) const {
    return "X" + len(q[0]) + " Y" + len(q[1]) + " Z" + len(q[2]);
  }
  // One arc from `from_deg` to `to_deg` on the circle (the direction's G2/G3, I J K to the centre).
  void arc(const DbbProgramCircle& c, const PlaneCode& pc, double from_deg, double to_deg, const std::string& note) {
    static const char* axis = "XYZ";
    static const char* offset = "IJK";
    const auto from = point(c, pc, from_deg), to = point(c, pc, to_deg);
    std::string s = (c.ccw == pc.ccw_is_g3) ? "G3" : "G2";
    for (const int k : {pc.a, pc.b}) s += std::string(" ") + axis[k] + len(to[static_cast<std::size_t>(k)]);
    for (const int k : {pc.a, pc.b}) {
      const auto i = static_cast<std::size_t>(k);
      s += std::string(" ") + offset[k] + len(p_.center_mm[i] - from[i]);
    }
    if (!feed_written_) {
      s += " F" + len(p_.feed_mm_per_min);
      feed_written_ = true;
    }
    line(s + " (" + note + ")");
  }

 private:
  const DbbProgram& p_;
  double scale_;
  bool feed_written_ = false;
  std::ostringstream out_;
};

std::string num_g(double v) {
  char b[32];
  std::snprintf(b, sizeof(b), "%g", v);
  return b;
}

std::string pin_text(int pin) {
  char b[8];
  std::snprintf(b, sizeof(b), "%02d", pin);
  return b;
}

}  // namespace

std::string format_dbb_program(const DbbProgram& p) {
  check(p);
  Writer w(p);
  w.line("%");
  w.line("(" + (p.title.empty() ? std::string("ballbar test") : p.title) + ")");
  w.line("(written by guideway program dbb; docs/linuxcnc.md. Runs: ccw = counter-clockwise seen from +n, n = a x b)");
  w.line(std::string(p.inch ? "G20" : "G21") + " G90 G91.1 G94 G40 G49 G80 (units, absolute, arc centres relative)");
  w.line(std::string("G64 P") + w.len(0.001) + " (blend within 1 um: the arcs meet on their tangent and do not stop)");
  std::string plane;
  std::array<double, 3> at{};
  bool first = true;
  int k = 0;
  for (const auto& c : p.circles) {
    ++k;
    const PlaneCode pc = plane_code(c.plane);
    const double sgn = c.ccw ? 1.0 : -1.0;
    const double t0 = c.start_deg - sgn * c.overshoot_deg, t1 = c.start_deg, t2 = t1 + sgn * c.data_arc_deg,
                 t3 = t2 + sgn * c.overshoot_deg;
    std::ostringstream name;
    name << "run " << k << ": " << (c.ccw ? "ccw" : "cw") << " in " << c.plane << ", r " << c.radius_mm
         << " mm, data arc " << c.data_arc_deg << " deg from " << c.start_deg << " deg";
    w.line("(" + name.str() + ")");
    if (plane != pc.code) {
      w.line(std::string(pc.code));
      plane = pc.code;
    }
    const auto start = w.point(c, pc, t0);
    const bool moved = first || std::hypot(start[0] - at[0], start[1] - at[1], start[2] - at[2]) > 1e-6;
    if (moved) w.line("G0 " + w.xyz(start) + " (the feed-in arc's start)");
    if (p.stop_to_mount && moved)
      w.line("M0 (mount the ballbar for the " + c.plane + " plane, r " + num_g(c.radius_mm) + " mm, then cycle start)");
    if (first && p.session_pin >= 0)
      w.line("M62 P" + std::to_string(p.session_pin) + " (motion.digital-out-" + pin_text(p.session_pin) +
             " rises with the feed-in arc: the Guideway session begins)");
    if (c.overshoot_deg > 0) w.arc(c, pc, t0, t1, "feed-in");
    if (c.data_arc_deg >= 360.0) {
      w.arc(c, pc, t1, t2, "data arc: a full circle");
    } else {
      w.arc(c, pc, t1, t2, "data arc");
    }
    if (c.overshoot_deg > 0) w.arc(c, pc, t2, t3, "feed-out");
    char dwell[32];
    std::snprintf(dwell, sizeof(dwell), "G4 P%.3f", p.pause_s);
    w.line(std::string(dwell) + " (standing still between runs)");
    at = w.point(c, pc, t3);
    first = false;
  }
  if (p.session_pin >= 0)
    w.line("M65 P" + std::to_string(p.session_pin) + " (after the dwell, the motion done: the session ends)");
  w.line("M2");
  w.line("%");
  return w.text();
}

double dbb_program_duration_s(const DbbProgram& p) {
  double arc_mm = 0;
  for (const auto& c : p.circles) arc_mm += (c.data_arc_deg + 2 * c.overshoot_deg) * deg * c.radius_mm;
  return arc_mm / (p.feed_mm_per_min / 60.0) + p.pause_s * static_cast<double>(p.circles.size());
}

std::vector<DbbProgramCircle> dbb_test_circles(const std::string& test, double radius_mm, const std::string& plane,
                                               double overshoot_deg) {
  std::vector<DbbProgramCircle> out;
  if (test == "standard") {
    for (const bool ccw : {true, false}) out.push_back({plane, ccw, radius_mm, 0.0, 360.0, overshoot_deg});
  } else if (test == "three-plane") {
    for (const char* pl : {"xy", "xz", "yz"}) {
      for (const bool ccw : {true, false}) {
        DbbProgramCircle c{pl, ccw, radius_mm, 0.0, 360.0, overshoot_deg};
        if (std::string(pl) != "xy") {
          c.data_arc_deg = 220.0;
          c.start_deg = ccw ? -20.0 : 200.0;  // the arc above the centre: the table is below
          c.overshoot_deg = std::min(overshoot_deg, 10.0);
        }
        out.push_back(c);
      }
    }
  } else {
    throw std::invalid_argument("test \"" + test + "\": standard or three-plane");
  }
  return out;
}

}  // namespace guideway::formats
