// The files of `guideway compensate` from the compensation's error maps (compensation.hpp: compensation_files):
// the per-joint tables, the INI lines, errors.csv, straightness.csv, with the headers that say what they hold.
#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "core/number_format.hpp"
#include "formats/compensation_files.hpp"
#include "models/compensation/compensation.hpp"
#include "models/compensation/compensation_common.hpp"

namespace guideway::models::compensation {

namespace {

using detail::letters_upper;

std::string estimate_text(const Term& t) {
  if (!t.determined) return t.name + " not determined";
  return t.name + " = " + printf_number("%.4g", t.value) + " +/- " + printf_number("%.2g", t.u);
}

std::vector<std::string> header_lines(const ErrorMap& m, const std::string& source) {
  std::vector<std::string> h;
  h.push_back("written by guideway compensate from " + source + "; error model: " + m.model +
              (m.model == "lai3" ? " (Lai's third-order model, its terms named as the diagnostics')"
                                 : " (the ballbar diagnostics)"));
  const auto& t0 = m.terms_of[0];
  h.push_back("measured circle: centre (" + printf_number("%.3f", t0.center_m * 1e3) + ", " +
              printf_number("%.3f", m.terms_of[1].center_m * 1e3) + ") mm in the " + m.plane + " plane, radius " +
              printf_number("%.3f", t0.radius_m * 1e3) +
              " mm; valid only over that range, in that plane and at that height");
  h.push_back("positions are relative to the axis' position at the circle centre (a DBB sees no constant offset)");
  std::string applied, left_out, undetermined, contradicted;
  for (const auto& t : m.terms) {
    if (t.use == Use::not_geometric) continue;
    const auto add = [&](std::string& list, const std::string& text) { list += (list.empty() ? "" : ", ") + text; };
    if (t.applied())
      add(applied, estimate_text(t));
    else if (!t.determined)
      add(undetermined, t.name);
    else if (!t.contradiction.empty())
      add(contradicted, estimate_text(t) + " (" + t.contradiction + ")");
    else
      add(left_out, estimate_text(t));
  }
  h.push_back("identified (value +/- standard uncertainty): " + (applied.empty() ? std::string("none") : applied));
  h.push_back("left out, not larger than twice their standard uncertainty (k = 2): " +
              (left_out.empty() ? std::string("none") : left_out));
  if (!undetermined.empty())
    h.push_back("left out, not determined by these runs (size or uncertainty beyond their circular deviation G): " +
                undetermined);
  if (!contradicted.empty()) h.push_back("left out, contradicting EXPLAIN on the same runs: " + contradicted);
  std::string other;
  for (const auto& t : m.terms)
    if (t.use == Use::not_geometric) other += (other.empty() ? "" : ", ") + estimate_text(t);
  if (!other.empty()) h.push_back("servo and friction effects, in no table: " + other);
  for (const auto& n : m.notes) h.push_back(n);
  return h;
}

}  // namespace

int joint_of(const std::string& axis) { return axis == "x" ? 0 : (axis == "y" ? 1 : 2); }

std::vector<std::string> compensation_file_names() {
  std::vector<std::string> names{"x.comp", "y.comp", "z.comp", "linuxcnc.ini", "errors.csv", "straightness.csv"};
  for (std::size_t k = 0, n = names.size(); k < n; ++k) names.push_back(names[k] + std::string(do_not_load_suffix));
  return names;
}

std::vector<OutputFile> compensation_files(const ErrorMap& m, const std::string& source) {
  return compensation_files(std::vector<ErrorMap>{m}, source);
}

namespace {

// Each axis' map once, from the first plane that sees it, with its plane's terms.
std::vector<std::pair<const ErrorMap*, std::size_t>> axes_once(const std::vector<ErrorMap>& planes) {
  std::vector<std::pair<const ErrorMap*, std::size_t>> out;
  for (const auto& m : planes)
    for (std::size_t k = 0; k < m.axes.size(); ++k)
      if (std::none_of(out.begin(), out.end(),
                       [&](const auto& a) { return a.first->axes[a.second].axis == m.axes[k].axis; }))
        out.emplace_back(&m, k);
  return out;
}

// The squareness of each plane as errors.csv's metadata (one plane: squareness_significant, as before).
void squareness_meta(const std::vector<ErrorMap>& planes, std::vector<std::pair<std::string, std::string>>& meta) {
  for (const auto& m : planes) {
    if (!m.squareness_known) continue;
    const std::string a = m.axes[0].axis, b = m.axes[1].axis;
    const auto adv = squareness_advice(m.squareness_rad);
    meta.emplace_back("squareness_" + a + b + "_urad", printf_number("%.3f", m.squareness_rad * 1e6));
    meta.emplace_back("squareness_" + a + b + "_u_urad", printf_number("%.3f", m.squareness_u_rad * 1e6));
    meta.emplace_back(
        planes.size() == 1 ? std::string("squareness_significant") : "squareness_" + a + b + "_significant",
        m.squareness_significant ? "true" : "false");
    meta.emplace_back("squareness_correction_" + a + "_um_per_100mm_" + b,
                      printf_number("%.3f", adv.correction_um_per_100mm));
  }
}

}  // namespace

std::vector<OutputFile> compensation_files(const std::vector<ErrorMap>& planes, const std::string& source) {
  if (planes.empty()) throw CompensationError("no plane to write compensation files of");
  std::vector<OutputFile> out;
  std::vector<std::string> head;
  std::string plane_names, table_names;
  for (const auto& m : planes) {
    plane_names += (plane_names.empty() ? "" : ",") + m.plane;
    for (const auto& l : header_lines(m, source))
      if (std::find(head.begin(), head.end(), l) == head.end()) head.push_back(l);
  }
  const auto axes = axes_once(planes);
  std::vector<formats::IniJoint> joints;
  for (const auto& [mp, k] : axes) {
    const ErrorMap& m = *mp;
    const AxisMap& am = m.axes[k];
    std::vector<formats::CompTriplet> table;
    for (std::size_t i = 0; i < am.nominal_m.size(); ++i)
      table.push_back({am.nominal_m[i] * 1e3, (am.nominal_m[i] + am.table_forward_m[i]) * 1e3,
                       (am.nominal_m[i] + am.table_reverse_m[i]) * 1e3});
    std::vector<std::string> c;
    c.push_back("LinuxCNC compensation table of joint " + std::to_string(joint_of(am.axis)) + " (axis " +
                letters_upper(am.axis) + "), COMP_FILE_TYPE = 0: nominal, actual moving +, actual moving - (mm)");
    c.push_back(
        "these comments follow the table because LinuxCNC stops reading at the first line that is not three numbers");
    c.insert(c.end(), head.begin(), head.end());
    c.push_back("in this table: scale, backlash and cyclic error of " + letters_upper(am.axis) +
                " (those applied above); straightness: straightness.csv (cross-axis), squareness: axis skew; both "
                "also in errors.csv");
    const auto& at = m.terms_of[k];
    if (at.cyclic_amplitude_m != 0.0) {
      if (at.cyclic_table_gain > 0)
        c.push_back("the cyclic part is multiplied by " + printf_number("%.4f", at.cyclic_table_gain) +
                    " = 1 / sinc^2(step / period): LinuxCNC's linear interpolation between lines " +
                    printf_number("%.3g", m.step_m * 1e3) + " mm apart attenuates a " +
                    printf_number("%.3g", at.cyclic_period_m * 1e3) +
                    " mm period by the inverse (errors.csv holds the error itself)");
      else
        c.push_back(
            "the cyclic error is NOT in this table: its period is shorter than two table steps (use a smaller "
            "circle or a finer --step-mm)");
    }
    out.push_back({am.axis + ".comp", formats::format_linuxcnc_comp(table, c)});
    joints.push_back({joint_of(am.axis), am.axis, am.axis + ".comp"});
    table_names += (table_names.empty() ? "" : " / ") + am.axis + ".comp";
  }
  std::vector<std::string> ic{"Guideway compensation: lines for the [JOINT_n] sections of the machine's INI file",
                              "copy " + table_names +
                                  " next to the INI file (COMP_FILE is read relative to it), "
                                  "then restart LinuxCNC",
                              "joint numbers assume trivial kinematics (X = 0, Y = 1, Z = 2): check your [KINS]"};
  for (const auto& l : head) ic.push_back(l);
  out.push_back({"linuxcnc.ini", formats::format_linuxcnc_ini(joints, ic)});

  std::vector<formats::ErrorMapRow> rows;
  for (const auto& [mp, k] : axes) {
    const AxisMap& am = mp->axes[k];
    for (std::size_t i = 0; i < am.nominal_m.size(); ++i)
      rows.push_back({am.axis, am.nominal_m[i] * 1e3, am.forward_m[i] * 1e6, am.reverse_m[i] * 1e6, am.across,
                      am.straightness_m[i] * 1e6});
  }
  std::vector<std::pair<std::string, std::string>> meta;
  meta.emplace_back("source", source);
  meta.emplace_back("plane", plane_names);
  meta.emplace_back("model", planes.front().model);
  squareness_meta(planes, meta);
  std::vector<std::string> ec = head;
  ec.push_back("forward_um / reverse_um: positioning error (actual - nominal) of the axis moving in + / -");
  ec.push_back("straightness_um: displacement of the axis along straightness_axis (ends relative to the centre)");
  for (const auto& m : planes) {
    const std::string a = m.axes[0].axis, b = m.axes[1].axis;
    ec.push_back("squareness (sign): actual " + a + " = " + a + " + q " + b + ", i.e. " + letters_upper(b) +
                 " leans towards +" + a + " for q > 0; um/m = urad");
  }
  if (planes.size() > 1)
    ec.push_back(
        "each axis once, from the first plane that sees it (its straightness along that plane's other axis; "
        "the other plane's in straightness.csv)");
  out.push_back({"errors.csv", formats::format_error_map_csv(rows, meta, ec)});

  // The cross-axis correction undoes the straightness: the other axis is commanded back by as much.
  std::vector<formats::CrossCorrectionRow> cross;
  for (const auto& m : planes)
    for (const auto& am : m.axes)
      if (am.straightness_applied)
        for (std::size_t i = 0; i < am.nominal_m.size(); ++i)
          cross.push_back({am.axis, am.nominal_m[i] * 1e3, am.across, -am.straightness_m[i] * 1e3});
  if (!cross.empty()) {
    std::vector<std::string> sc = head;
    sc.push_back(
        "correction_mm: added to the command of corrected_axis, interpolated linearly in moving_axis' "
        "commanded position (minus the straightness of moving_axis along corrected_axis; ends relative "
        "to the centre)");
    sc.push_back(
        "load it as a cross-axis / straightness compensation table (docs/compensation.md); a per-joint "
        "table cannot hold it");
    for (const auto& m : planes)
      for (const auto& am : m.axes)
        if (!am.straightness_applied)
          sc.push_back("no rows for " + am.axis + (planes.size() > 1 ? " along " + am.across : std::string()) +
                       ": its straightness is not larger than twice its uncertainty");
    out.push_back({"straightness.csv",
                   formats::format_straightness_csv(cross, {{"source", source}, {"plane", plane_names}}, sc)});
  }
  return out;
}

}  // namespace guideway::models::compensation
