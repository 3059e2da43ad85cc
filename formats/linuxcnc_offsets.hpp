#pragma once
// The squareness and the straightness as LinuxCNC can load them: external offsets through HAL
// (docs/linuxcnc.md, "The squareness and the straightness"). A per-joint COMP_FILE is indexed by the
// joint's own position and cannot hold either; LinuxCNC's external offsets (axis.L.eoffset-counts, enabled
// by [AXIS_L]OFFSET_AV_RATIO) move an axis by what HAL computes every servo period. For each corrected
// axis and each axis its correction depends on, a `lincurve` (LinuxCNC's stock lookup table, at most 16
// points, linear between them, end values beyond) maps the moving axis' commanded position (axis.L.pos-cmd)
// to the correction in counts of 1 nm, summed per corrected axis (`sum2`), held at 0 until the machine is on
// and homed (`and2`, `conv_bit_float`, `mult2`: LinuxCNC applies the change of the counts since machine on)
// and converted (`conv_float_s32`) into axis.L.eoffset-counts with axis.L.eoffset-scale = 0.000001 mm. The squareness is linear: the axis
// skew of the virtual machine's controller (machine::ControllerCorrection: x -= q_xy y + q_xz z, y -= q_yz z)
// folded into the same curve as the moving axis' straightness row of straightness.csv, whose table is
// resampled onto the points the lookup holds (the largest error that costs is reported). Pure functions;
// thread safe.

#include <map>
#include <string>
#include <vector>

#include "formats/compensation_files.hpp"

namespace guideway::formats {

// One axis' correction as a function of another axis' commanded position.
struct OffsetCurve {
  std::string corrected_axis;        // "x"
  std::string moving_axis;           // "y"
  std::vector<double> position_mm;   // ascending, at most linuxcnc_lincurve_points
  std::vector<double> offset_mm;     // added to the corrected axis
  double resampling_error_mm = 0.0;  // the largest difference from the straightness table it came from
};

inline constexpr std::size_t linuxcnc_lincurve_points = 16;  // lincurve's personality limit
inline constexpr double linuxcnc_offset_scale_mm = 1e-6;     // one eoffset count: 1 nm

// The curves of an axis skew (`skew_rad` by plane "xy", "xz", "yz": the squareness q of errors.csv, the
// correction x -= q y) and of straightness.csv's rows. `travel_mm`: the skew is written out to +/- it (a
// lookup holds its end values beyond its points). Throws std::invalid_argument for a plane or axis
// name that is none, or an empty result.
std::vector<OffsetCurve> linuxcnc_offset_curves(const std::map<std::string, double>& skew_rad,
                                                const std::vector<CrossCorrectionRow>& cross, double travel_mm);

// The curve's value at a position, as lincurve computes it.
double offset_curve_at(const OffsetCurve& curve, double position_mm);

// The HAL file (loadrt/addf/setp/net lines, `comment_lines` first as `#` comments) and the INI lines it
// needs ([AXIS_L]OFFSET_AV_RATIO for each corrected axis, [HAL]HALFILE = hal_name).
std::string format_linuxcnc_offsets_hal(const std::vector<OffsetCurve>& curves,
                                        const std::vector<std::string>& comment_lines);
std::string format_linuxcnc_offsets_ini(const std::vector<OffsetCurve>& curves, const std::string& hal_name,
                                        double offset_av_ratio);

}  // namespace guideway::formats
