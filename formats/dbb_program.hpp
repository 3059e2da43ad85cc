#pragma once
// A ballbar test as the G-code program a controller runs (RS274NGC as LinuxCNC reads it; docs/linuxcnc.md,
// "The test program"): each circle of the test traced as its feed-in arc, its data arc and its feed-out arc,
// tangent to each other on the circle (no stop between them), in the machine's units (G21 mm, G20 inch).
// The directions are the runs' (docs/conventions.md: ccw seen from +n, n = a x b of the plane ab); in
// G-code's planes G17 (XY), G18 (ZX), G19 (YZ) that is G3 for ccw in XY and YZ and G2 in XZ (G18's arcs
// turn about +Y, ours about -Y). Pure functions; thread safe.

#include <array>
#include <string>
#include <vector>

namespace guideway::formats {

struct DbbProgramCircle {
  std::string plane = "xy";  // xy | xz | yz
  bool ccw = true;
  double radius_mm = 100.0;
  double start_deg = 0.0;       // where the data arc starts (angle from the plane's first axis towards its second)
  double data_arc_deg = 360.0;  // 360, or a partial arc (a vertical plane's 220)
  double overshoot_deg = 45.0;  // the feed-in arc before it and the feed-out arc after it
};

struct DbbProgram {
  std::string title;                     // a comment line naming the test
  std::array<double, 3> center_mm{};     // the circles' commanded centre, machine coordinates (G53)
  double feed_mm_per_min = 1000.0;
  bool inch = false;                     // G20: coordinates and feed written in inches
  std::vector<DbbProgramCircle> circles;
  double pause_s = 1.0;                  // dwell after each circle (the session tells runs apart by it)
  int session_pin = 0;                   // motion.digital-out-NN raised over the test (M62/M65 P NN); -1: none
  bool stop_to_mount = true;             // M0 at the first feed-in's start: the operator mounts the bar
};

// The program's text. Throws std::invalid_argument for a circle it cannot write (a radius not > 0, an
// unknown plane, a data arc outside 180..360 deg, a feed-in arc outside 0..90 deg, a feed not > 0).
std::string format_dbb_program(const DbbProgram& program);

// Seconds the program's feed moves take at its feed (the feed-in, data and feed-out arcs), dwells included.
double dbb_program_duration_s(const DbbProgram& program);

// The circles of a test: "standard" (ccw then cw, 360 deg, in `plane`), "three-plane" (xy 360 deg, then xz
// and yz 220 deg from -20 deg ccw / 200 deg cw, z above the centre, feed-in arcs of at most 10 deg there),
// as guidewayd's DBB session and the emulator trace them. Throws std::invalid_argument for another test.
std::vector<DbbProgramCircle> dbb_test_circles(const std::string& test, double radius_mm, const std::string& plane,
                                               double overshoot_deg);

}  // namespace guideway::formats
