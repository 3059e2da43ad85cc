// The squareness and the straightness as LinuxCNC external offsets (linuxcnc_offsets.hpp): the lookup tables and their
// HAL lines.
#include "formats/linuxcnc_offsets.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <sstream>
#include <stdexcept>

namespace guideway::formats {

namespace {

void check_axis(const std::string& a) {
  if (a != "x" && a != "y" && a != "z") throw std::invalid_argument("axis \"" + a + "\": x, y or z");
}

// A table (ascending positions) linear between its points, end values beyond: lincurve's and
// machine::CrossCompensation's rule.
double table_at(const std::vector<double>& at, const std::vector<double>& value, double x) {
  if (at.empty()) return 0.0;
  if (x <= at.front()) return value.front();
  if (x >= at.back()) return value.back();
  const auto hi = static_cast<std::size_t>(std::upper_bound(at.begin(), at.end(), x) - at.begin());
  const double f = (x - at[hi - 1]) / (at[hi] - at[hi - 1]);
  return value[hi - 1] + f * (value[hi] - value[hi - 1]);
}

std::string num(const char* fmt, double v) {
  char b[64];
  std::snprintf(b, sizeof(b), fmt, v);
  return b;
}

std::string upper(const std::string& a) {
  std::string s = a;
  for (auto& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// The curve of one (corrected, moving) pair: the straightness table resampled to what a lookup holds,
// the skew added (linear, so exact at every point), and the travel's ends where the skew goes on.
OffsetCurve make_curve(const std::string& corrected, const std::string& moving, double skew_rad,
                       const std::vector<double>& at, const std::vector<double>& cross, double travel_mm) {
  OffsetCurve c{corrected, moving, {}, {}, 0.0};
  std::vector<double> points;
  if (at.size() >= 2) {
    const std::size_t inner = std::min(at.size(), linuxcnc_lincurve_points - 2);
    for (std::size_t k = 0; k < inner; ++k)
      points.push_back(at.front() + (at.back() - at.front()) * static_cast<double>(k) / static_cast<double>(inner - 1));
  } else if (at.size() == 1) {
    points.push_back(at.front());
  }
  if (points.empty() || points.front() > -travel_mm) points.insert(points.begin(), -travel_mm);
  if (points.back() < travel_mm) points.push_back(travel_mm);
  for (const double p : points) {
    c.position_mm.push_back(p);
    c.offset_mm.push_back(table_at(at, cross, p) - skew_rad * p);
  }
  for (const double p : at) {
    const double exact = table_at(at, cross, p) - skew_rad * p;
    c.resampling_error_mm = std::max(c.resampling_error_mm, std::abs(offset_curve_at(c, p) - exact));
  }
  return c;
}

}  // namespace

double offset_curve_at(const OffsetCurve& curve, double position_mm) {
  return table_at(curve.position_mm, curve.offset_mm, position_mm);
}

std::vector<OffsetCurve> linuxcnc_offset_curves(const std::map<std::string, double>& skew_rad,
                                                const std::vector<CrossCorrectionRow>& cross, double travel_mm) {
  if (!(travel_mm > 0) || !std::isfinite(travel_mm)) throw std::invalid_argument("the travel must be > 0 mm");
  // (corrected, moving) -> its straightness table, and its skew
  std::map<std::pair<std::string, std::string>, std::pair<std::vector<double>, std::vector<double>>> tables;
  std::map<std::pair<std::string, std::string>, double> skews;
  for (const auto& [plane, q] : skew_rad) {
    if (plane != "xy" && plane != "xz" && plane != "yz") throw std::invalid_argument("plane \"" + plane + "\"");
    if (!std::isfinite(q)) throw std::invalid_argument("the " + plane + " squareness is not a number");
    if (q != 0.0) skews[{plane.substr(0, 1), plane.substr(1, 1)}] += q;  // the first axis corrected by the second
  }
  for (const auto& r : cross) {
    check_axis(r.moving_axis);
    check_axis(r.corrected_axis);
    auto& t = tables[{r.corrected_axis, r.moving_axis}];
    if (!t.first.empty() && !(r.position_mm > t.first.back()))
      throw std::invalid_argument("straightness rows of " + r.moving_axis + " do not ascend");
    t.first.push_back(r.position_mm);
    t.second.push_back(r.correction_mm);
  }
  std::set<std::pair<std::string, std::string>> pairs;
  for (const auto& [k, v] : tables) pairs.insert(k);
  for (const auto& [k, v] : skews) pairs.insert(k);
  std::vector<OffsetCurve> out;
  for (const auto& k : pairs) {
    const auto t = tables.find(k);
    const auto s = skews.find(k);
    out.push_back(make_curve(k.first, k.second, s == skews.end() ? 0.0 : s->second,
                             t == tables.end() ? std::vector<double>{} : t->second.first,
                             t == tables.end() ? std::vector<double>{} : t->second.second, travel_mm));
  }
  if (out.empty()) throw std::invalid_argument("no squareness and no straightness to correct");
  return out;
}

std::string format_linuxcnc_offsets_hal(const std::vector<OffsetCurve>& curves,
                                        const std::vector<std::string>& comment_lines) {
  std::ostringstream o;
  for (const auto& l : comment_lines) o << "# " << l << "\n";
  std::map<std::string, std::vector<std::size_t>> by_axis;  // corrected axis -> its curves
  std::string personality;
  for (std::size_t i = 0; i < curves.size(); ++i) {
    by_axis[curves[i].corrected_axis].push_back(i);
    personality += (i ? "," : "") + std::to_string(curves[i].position_mm.size());
  }
  std::size_t sums = 0;
  for (const auto& [axis, list] : by_axis) sums += list.size() - 1;
  o << "loadrt lincurve count=" << curves.size() << " personality=" << personality << "\n";
  o << "loadrt conv_float_s32 count=" << by_axis.size() << "\n";
  o << "loadrt mult2 count=" << by_axis.size() << "\n";
  o << "loadrt and2 count=1\n";
  o << "loadrt conv_bit_float count=1\n";
  if (sums > 0) o << "loadrt sum2 count=" << sums << "\n";
  // LinuxCNC applies the change of eoffset-counts since the machine was turned on (its register is reset
  // at each machine on): the counts stay 0 until the machine is on and homed, then the correction comes
  // in whole, through the offsets' own planner.
  o << "\n# The correction only once the machine is on and homed (counts 0 before: LinuxCNC's register counts\n"
    << "# from the value at machine on)\n";
  o << "addf and2.0 servo-thread\n";
  o << "addf conv-bit-float.0 servo-thread\n";
  o << "net guideway-machine-on motion.motion-enabled => and2.0.in0\n";
  o << "net guideway-all-homed motion.is-all-homed => and2.0.in1\n";
  o << "net guideway-offsets-on and2.0.out => conv-bit-float.0.in\n";
  o << "net guideway-offsets-gate conv-bit-float.0.out\n";
  for (std::size_t i = 0; i < curves.size(); ++i) {
    const auto& c = curves[i];
    o << "\n# " << upper(c.corrected_axis) << " corrected by " << upper(c.moving_axis)
      << "'s commanded position (mm -> counts of 1 nm)\n";
    o << "addf lincurve." << i << " servo-thread\n";
    o << "net guideway-" << c.moving_axis << "-pos-cmd axis." << c.moving_axis << ".pos-cmd => lincurve." << i
      << ".in\n";
    for (std::size_t k = 0; k < c.position_mm.size(); ++k) {
      char idx[8];
      std::snprintf(idx, sizeof(idx), "%02zu", k);
      o << "setp lincurve." << i << ".x-val-" << idx << " " << num("%.6f", c.position_mm[k]) << "\n";
      o << "setp lincurve." << i << ".y-val-" << idx << " " << num("%.3f", c.offset_mm[k] / linuxcnc_offset_scale_mm)
        << "\n";
    }
  }
  std::size_t conv = 0, sum = 0;
  for (const auto& [axis, list] : by_axis) {
    o << "\n# " << upper(axis) << "'s external offset\n";
    std::string signal = "guideway-" + axis + "-offset-" + std::to_string(list[0]);
    o << "net " << signal << " lincurve." << list[0] << ".out";
    for (std::size_t j = 1; j < list.size(); ++j) {
      o << " => sum2." << sum << ".in0\n";
      o << "net guideway-" << axis << "-offset-" << list[j] << " lincurve." << list[j] << ".out => sum2." << sum
        << ".in1\n";
      o << "addf sum2." << sum << " servo-thread\n";
      signal = "guideway-" + axis + "-offset-sum" + std::to_string(sum);
      o << "net " << signal << " sum2." << sum << ".out";
      ++sum;
    }
    o << " => mult2." << conv << ".in0\n";
    o << "net guideway-offsets-gate => mult2." << conv << ".in1\n";
    o << "addf mult2." << conv << " servo-thread\n";
    o << "net guideway-" << axis << "-offset-gated mult2." << conv << ".out => conv-float-s32." << conv << ".in\n";
    o << "addf conv-float-s32." << conv << " servo-thread\n";
    o << "net guideway-" << axis << "-eoffset-counts conv-float-s32." << conv << ".out => axis." << axis
      << ".eoffset-counts\n";
    o << "setp axis." << axis << ".eoffset-scale " << num("%.6f", linuxcnc_offset_scale_mm) << "\n";
    o << "setp axis." << axis << ".eoffset-enable 1\n";
    ++conv;
  }
  return o.str();
}

std::string format_linuxcnc_offsets_ini(const std::vector<OffsetCurve>& curves, const std::string& hal_name,
                                        double offset_av_ratio) {
  std::set<std::string> axes;
  for (const auto& c : curves) axes.insert(c.corrected_axis);
  std::ostringstream o;
  o << "# Guideway's squareness and straightness as LinuxCNC's external offsets (docs/linuxcnc.md): add these\n"
    << "# lines to the machine's INI and copy " << hal_name << " next to it.\n";
  for (const auto& a : axes) {
    o << "[AXIS_" << upper(a) << "]\n"
      << "# the part of the axis' velocity and acceleration kept for the external offset (the planner's limits\n"
      << "# shrink by it)\n"
      << "OFFSET_AV_RATIO = " << num("%g", offset_av_ratio) << "\n";
  }
  o << "[HAL]\nHALFILE = " << hal_name << "\n";
  return o.str();
}

}  // namespace guideway::formats
