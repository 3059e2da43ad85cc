// What the data arcs of DBB runs hold (arcs.hpp): which terms a partial arc or a gap leaves unseparated, said in words.
#include "models/dbb/arcs.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numbers>
#include <sstream>

#include "core/number_format.hpp"
#include "models/dbb/geometry.hpp"
#include "results/parameters.hpp"

namespace guideway::models::dbb {

namespace {

constexpr double deg = std::numbers::pi / 180.0;

std::string fixed1(double v) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(1) << v;
  return o.str();
}

std::string angles_text(const std::vector<double>& list) {
  std::string out;
  for (std::size_t i = 0; i < list.size(); ++i)
    out += (i == 0 ? "" : (i + 1 == list.size() ? " and " : ", ")) + std::to_string(std::lround(list[i]));
  return out;
}

// Whether the run passes the angle with samples on both sides of it (at least a degree each way): a
// reversal there shows as the step of the lost motion. A gap over it does not hide that step, only its shape.
bool holds(const formats::DbbRun& run, double angle_rad) {
  if (formats::dbb_run_full_circle(run)) return true;
  const double lo = std::min(run.angle_rad.front(), run.angle_rad.back()) + 1.0 * deg;
  const double hi = std::max(run.angle_rad.front(), run.angle_rad.back()) - 1.0 * deg;
  const double k = std::ceil((lo - angle_rad) / (2 * std::numbers::pi));
  return angle_rad + k * 2 * std::numbers::pi <= hi;
}

std::string axis_name(const std::string& plane, int axis) {
  std::string a = results::axis_letter(plane, axis);
  for (char& c : a) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return a;
}

// The plane axis (0, 1) a reversal term is of, -1 for another term. The diagnostics name the axis by its
// letter, Lai's by x and y whatever the plane.
int reversal_axis(const std::string& name, const std::string& plane) {
  for (const char* prefix :
       {"backlash_", "lateral_play_", "reversal_spike_decay_", "reversal_spike_delay_", "reversal_spike_"}) {
    const std::string p(prefix);
    if (name.rfind(p, 0) != 0 || name.size() < p.size() + 2 || name[p.size() + 1] != '_') continue;
    const std::string letter(1, name[p.size()]);
    if (letter == results::axis_letter(plane, 0)) return 0;
    if (letter == results::axis_letter(plane, 1)) return 1;
    if (letter == "x") return 0;  // Lai's
    if (letter == "y") return 1;
    return -1;
  }
  return -1;
}

// Whether some run holds a sample where a reversal spike of the axis lives: after one of its reversals, within
// the extent of a spike of the decay the diagnostics take when none stands out (geometry.hpp). Gaps there
// leave the spike's column without a sample: its height cannot be read.
bool holds_spike_window(const std::vector<formats::DbbRun>& runs, int axis) {
  const double phase = axis == 0 ? 0.0 : std::numbers::pi / 2;
  return std::any_of(runs.begin(), runs.end(), [&](const formats::DbbRun& r) {
    const double window_rad = spike_extent_decays * assumed_spike_decay_s * r.feed_m_per_s / r.radius_m;
    return std::any_of(r.angle_rad.begin(), r.angle_rad.end(), [&](double zeta) {
      const double since = angle_since_reversal_rad(zeta, phase, r.dir());
      return since > 0 && since <= window_rad;
    });
  });
}

}  // namespace

AxisReversals reversals_in_arcs(const std::vector<formats::DbbRun>& runs, int axis) {
  AxisReversals out;
  for (const double at : axis == 0 ? std::vector<double>{0.0, 180.0} : std::vector<double>{90.0, 270.0}) {
    const bool seen =
        std::any_of(runs.begin(), runs.end(), [&](const formats::DbbRun& r) { return holds(r, at * deg); });
    (seen ? out.seen_deg : out.missed_deg).push_back(at);
  }
  return out;
}

std::string arcs_text(const std::vector<formats::DbbRun>& runs) {
  std::vector<std::string> seen;
  for (const auto& r : runs) {
    if (r.angle_rad.empty()) continue;
    const std::string t = formats::dbb_run_full_circle(r)
                              ? std::string("360 deg")
                              : fixed1(r.angle_rad.front() / deg) + " to " + fixed1(r.angle_rad.back() / deg) + " deg";
    if (std::find(seen.begin(), seen.end(), t) == seen.end()) seen.push_back(t);
  }
  std::string out;
  for (const auto& s : seen) out += (out.empty() ? "" : ", ") + s;
  return out;
}

// More gaps than this in a run are said in one note.
constexpr std::size_t max_gaps_described = 3;

std::vector<std::string> arc_notes(const std::vector<formats::DbbRun>& runs, const std::string& plane) {
  std::vector<std::string> notes;
  bool partial = false, gappy = false;
  for (const auto& r : runs) {
    const auto gaps = formats::dbb_run_gaps(r);
    if (!formats::dbb_run_full_circle(r)) {
      partial = true;
      const double arc = r.data_arc_rad > 0 ? r.data_arc_rad : formats::dbb_run_arc_rad(r);
      notes.push_back(r.source + ": a partial data arc of " + fixed1(arc / deg) + " deg (" +
                      fixed1(r.angle_rad.front() / deg) + " to " + fixed1(r.angle_rad.back() / deg) + " deg)");
    }
    gappy = gappy || !gaps.empty();
    if (gaps.size() > max_gaps_described) {  // a recording that lost samples often: one line, not one per gap
      double lost_deg = 0, lost_s = 0;
      for (const auto& g : gaps) {
        lost_deg += g.angle_rad() / deg;
        lost_s += g.duration_s();
      }
      notes.push_back(r.source + ": " + std::to_string(gaps.size()) + " gaps, " + fixed1(lost_deg) + " deg (" +
                      fixed1(lost_s) + " s) in all, the first " + formats::describe_gap(gaps.front()) +
                      "; the data in them is lost, the fit uses the samples there are (its u grows accordingly)");
      continue;
    }
    for (const auto& g : gaps)
      notes.push_back(r.source + ": " + formats::describe_gap(g) +
                      "; the data in it is lost, the fit uses the samples there are (its u grows accordingly)");
  }
  if (!partial && !gappy) return notes;
  for (int axis = 0; axis < 2; ++axis) {
    const AxisReversals rev = reversals_in_arcs(runs, axis);
    std::string t = axis_name(plane, axis) + " reverses at " + (axis == 0 ? "0 and 180" : "90 and 270") + " deg: ";
    if (rev.missed_deg.empty())
      t += "both reversals lie inside the data (" + arcs_text(runs) + ")";
    else if (rev.seen_deg.empty())
      t += "neither lies inside the data arcs (" + arcs_text(runs) +
           "): its backlash, lateral play and reversal spike cannot be read and are not fitted";
    else
      t += angles_text(rev.seen_deg) + " deg inside the data, " + angles_text(rev.missed_deg) + " deg outside (" +
           arcs_text(runs) + "): its reversal terms are read from the one reversal";
    notes.push_back(t);
  }
  if (partial)
    notes.push_back(
        "G, H and the deviations are over the data arc only (ISO 230-4 on a partial arc), about the least-squares "
        "circle of that arc, whose centre on a partial arc takes up part of the scale and squareness signatures: "
        "their u is larger than a full circle's");
  return notes;
}

std::string why_unidentifiable(const std::string& name, const std::vector<formats::DbbRun>& runs,
                               const std::string& plane) {
  const int axis = reversal_axis(name, plane);
  if (axis >= 0) {
    const AxisReversals rev = reversals_in_arcs(runs, axis);
    if (rev.seen_deg.empty())
      return "no reversal of " + axis_name(plane, axis) + " lies inside the data arcs (" + arcs_text(runs) + "; " +
             axis_name(plane, axis) + " reverses at " + angles_text(rev.missed_deg) +
             " deg): without one its lost motion is a constant offset the centre takes up";
    if (name.rfind("reversal_spike", 0) == 0 && !holds_spike_window(runs, axis))
      return "no run holds a sample in the first moments after a reversal of " + axis_name(plane, axis) + " (" +
             printf_number("%g", spike_extent_decays) + " decay times of " +
             printf_number("%g", assumed_spike_decay_s * 1e3) +
             " ms), where a reversal spike rises and decays: the gaps there take them, so its height cannot be read";
  }
  const bool flat = std::all_of(runs.begin(), runs.end(), [](const formats::DbbRun& r) { return r.height_m < 1e-9; });
  for (const results::Parameter* p : {&results::lai_c0_plus_d1, &results::lai_c1, &results::lai_c2, &results::lai_d2,
                                      &results::lai_d3, &results::lai_e1, &results::lai_e2, &results::lai_e3})
    if (flat && name == p->name)
      return "it moves the ball along the plane's normal, which an in-plane bar (h = 0) does not read";
  if (name == results::lai_a3.name || name == results::lai_b3.name)
    return "on one radius cos^3 sin + sin^3 cos = sin cos: the cubic straightness and the squareness share a "
           "signature (docs/conventions.md)";
  const bool ccw = std::any_of(runs.begin(), runs.end(),
                               [](const formats::DbbRun& r) { return r.direction == formats::DbbDirection::ccw; });
  const bool cw = std::any_of(runs.begin(), runs.end(),
                              [](const formats::DbbRun& r) { return r.direction == formats::DbbDirection::cw; });
  if ((name == results::name(results::squareness) || name == results::name(results::servo_mismatch) ||
       name == std::string(results::lai_a1.name) ||
       name == results::name_in(results::servo_mismatch, results::lai3_group)) &&
      !(ccw && cw))
    return "squareness and servo mismatch have the same signature (sin zeta cos zeta) in one direction: a run each "
           "way tells them apart";
  if (name == results::lai_a1.name)
    return "on one radius the squareness shares the sin cos signature with the cubic straightness a3, b3 "
           "(docs/conventions.md)";
  return "over the data arcs (" + arcs_text(runs) +
         ") its signature is a combination of the other terms' (fit.combinations gives what the runs determine)";
}

}  // namespace guideway::models::dbb
