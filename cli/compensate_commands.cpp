// `guideway compensate dbb RUN.csv... --out-dir DIR` (or `--latest`: the daemon's latest DBB session):
// the error map of the identified terms and the files a controller loads (LinuxCNC per-joint tables,
// INI lines, errors.csv; models/compensation). `--verify --machine FILE` traces the same test again on
// the virtual machine tool with those tables loaded and prints before/after (docs/compensation.md).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli/commands.hpp"
#include "cli/daemon_client.hpp"
#include "cli/params_print.hpp"
#include "cli/progress.hpp"
#include "core/atomic_file.hpp"
#include "core/number_format.hpp"
#include "formats/compensation_files.hpp"
#include "models/compensation/compensation.hpp"
#include "models/compensation/verification.hpp"
#include "models/dbb/identify.hpp"
#include "models/dbb/three_planes.hpp"
#include "results/parameters.hpp"
#include "results/result_header.hpp"
#include "results/session_kinds.hpp"
#include "simulators/machine/dbb_runs.hpp"

namespace guideway::cli {

namespace {

namespace fs = std::filesystem;

struct Opts {
  std::vector<std::string> files;
  std::string out_dir, machine, axes;
  std::vector<double> center_mm;
  double step_mm = 0;
  bool json = false, verify = false, latest = false, quiet = false;
};

const models::dbb::Estimate* find(const models::dbb::Identification& id, const std::string& name) {
  for (const auto& e : id.diagnostics)
    if (e.name == name) return &e;
  return nullptr;
}

// The run files of the daemon's latest DBB session (its PARAMS' derived files).
std::vector<std::string> latest_session_runs(const std::string& socket, std::string& session) {
  DaemonClient c = connect_daemon(socket);
  const nlohmann::json r =
      c.request(results::request(results::RequestClass::params, {{"kind", results::dbb_kind.name}}),
                results::MessageClass::params);
  throw_if_error(r);
  const results::ResultHeader header = results::read_header(r);
  session = header.session.empty() ? "latest session" : header.session;
  std::vector<std::string> out;
  for (const std::string& path : header.derived)
    if (fs::path(path).extension() == ".csv") out.push_back(path);
  if (out.empty())
    throw std::runtime_error("compensate: the daemon's latest DBB session (" + session +
                             ") left no run files (was it recorded?); give the run files instead");
  return out;
}

using models::compensation::Refusal;
using models::compensation::refused;
using models::compensation::Verification;

// A value as people read it, with its unit: "-10.71 ± 0.18 ppm" (results::shown).
std::string shown_with_unit(const std::string& name, double value, double u, const std::string& plane,
                            std::string_view group = {}) {
  const results::Shown s = results::shown(name, value, u, plane, group);
  return s.value + (s.unit.empty() ? "" : " " + s.unit);
}

// Lai's group in the catalogue: its "backlash_y_um" is the plane's second axis.
constexpr std::string_view lai_group = results::lai_S_x.group;

// The refused files renamed NAME.do-not-load (a file named x.comp invites loading it), linuxcnc.ini
// rewritten for the tables that remain (models/compensation::apply_refusals); the refusals as text and JSON.
std::string mark_refused(const Verification& v, const std::string& plane, const std::string& out_dir,
                         const std::vector<std::string>& axes, const std::string& source, nlohmann::json& j) {
  const std::vector<Refusal>& list = v.refused;
  std::ostringstream o;
  nlohmann::json jl = nlohmann::json::array();
  for (const auto& r : models::compensation::apply_refusals(v, out_dir, axes, source)) {
    o << "  DO NOT LOAD " << (r.file == "axis skew" ? "the squareness as axis skew" : r.file) << ": " << r.why
      << (r.renamed_to.empty() ? "" : "; renamed " + fs::path(r.renamed_to).filename().string()) << "\n";
    jl.push_back({{"file", r.file}, {"why", r.why}, {"renamed_to", r.renamed_to}});
  }
  j["do_not_load"] = jl;
  j["loadable"] = v.loadable;
  j["g_loadable_um"] = v.g_loadable;
  j["g_loadable_measured_um"] = v.g_loadable_measured;
  if (!v.loadable.empty() && !v.g_loadable.empty()) {
    std::string set, runs;
    for (const auto& f : v.loadable) set += (set.empty() ? "" : " + ") + f;
    for (std::size_t k = 0; k < v.g_loadable.size() && k < v.g_before.size(); ++k)
      runs += (runs.empty() ? "" : ", ") + printf_number("%.3f", v.g_before[k]) + " -> " +
              printf_number("%.3f um", v.g_loadable[k]) +
              (v.g_before[k] > 0 ? printf_number(" (%.0f %%)", 100 * v.g_loadable[k] / v.g_before[k]) : std::string());
    o << "  with what is fit to load (" << set << "), G run by run: " << runs;
    if (!v.beside.empty()) {
      std::string measured;
      for (std::size_t k = 0; k < v.g_loadable_measured.size() && k < v.g_before_measured.size(); ++k)
        measured += (measured.empty() ? "" : ", ") + printf_number("%.3f", v.g_before_measured[k]) + " -> " +
                    printf_number("%.3f um", v.g_loadable_measured[k]);
      o << "; as measured: " << measured;
    }
    o << "\n";
  }
  if (!list.empty()) {
    const bool none_left =
        std::all_of(axes.begin(), axes.end(), [&](const std::string& a) { return refused(list, a + ".comp"); });
    if (none_left)
      o << "  no table of the " << plane << " plane is fit to load: with any of them some run's G is larger than "
        << "before\n";
  } else {
    o << "  loaded together, the files (and the skew) leave no run's G larger than before: fit to load\n";
  }
  return o.str();
}

// What became of a map term: where it went (and whether that file may be loaded), or why it was left out.
std::string term_status(const models::compensation::Term& t, const models::compensation::ErrorMap& map,
                        const Verification& v, const std::vector<Refusal>& refusals, bool seen, double ratio) {
  namespace comp = models::compensation;
  if (std::string why = comp::left_out_in_words(t, map); !why.empty()) return why;
  switch (t.use) {
    case comp::Use::table: {
      const std::string file =
          (t.name.find("_" + map.axes[0].axis + "_") != std::string::npos ? map.axes[0].axis : map.axes[1].axis) +
          ".comp";
      if (refused(refusals, file)) return "in " + file + ": DO NOT LOAD (below)";
      return !seen ? "compensated (no longer detected)"
                   : (ratio < 3 ? "compensated (< 3 u)" : "compensated, NOT below 3 u");
    }
    case comp::Use::map_only:  // the squareness
      if (!v.skew) return "not applied";
      return refused(refusals, "axis skew") ? "axis skew: DO NOT ENTER (below)" : "axis skew (not a per-joint table)";
    case comp::Use::cross_table:
      if (!v.cross) return "not applied";
      return refused(refusals, "straightness.csv") ? "in straightness.csv: DO NOT LOAD (below)"
                                                   : "cross-axis correction (straightness.csv)";
    default:
      return "servo/friction: no table";
  }
}

double largest(const std::vector<double>& g) { return g.empty() ? NAN : *std::max_element(g.begin(), g.end()); }

// What G is of, when the effects fitted beside were taken out of it, and G as measured.
std::string g_basis_text(const Verification& v) {
  if (v.beside.empty()) return "";
  std::string list;
  for (const auto& e : v.beside) list += (list.empty() ? "" : ", ") + e;
  std::string runs;
  for (std::size_t k = 0; k < v.g_before_measured.size() && k < v.g_after_measured.size(); ++k)
    runs += (runs.empty() ? "" : ", ") + printf_number("%.3f", v.g_before_measured[k]) + " -> " +
            printf_number("%.3f um", v.g_after_measured[k]);
  return "  G here is of the readings less what EXPLAIN found and no table holds (" + list +
         ", fitted beside on the runs before); as measured, run by run: " + runs + "\n";
}

// A value and its u as the verification prints them, or "not determined" (compensation::determined).
std::string value_text(const models::dbb::Estimate& e, const models::compensation::ErrorMap& map, double g_um) {
  if (!models::compensation::determined(e.name, e.value, e.u, g_um, map.terms_of[0].radius_m, map.feed_m_per_s))
    return "not determined";
  return shown_with_unit(e.name, e.value, e.u, map.plane);
}

constexpr const char* backlash_step_status = "the tables' backlash step, not stiction (below)";

// What is still above 3 u after, apart from the spikes the tables' backlash step makes
// (compensation::spike_from_backlash_step), which are said with their cause.
std::string left_after_text(const models::compensation::ErrorMap& map, const Verification& v, double g1) {
  std::string left, step;
  for (const auto& e : v.after.diagnostics) {
    if (!e.fitted || !std::isfinite(e.u) || !(std::abs(e.value) > 3 * e.u) || e.name.starts_with("run") ||
        e.name.starts_with("center_offset") || e.name.starts_with("circular_") ||
        !models::compensation::determined(e.name, e.value, e.u, g1, map.terms_of[0].radius_m, map.feed_m_per_s))
      continue;
    const std::string text =
        results::label_of(e.name, map.plane) + " " + shown_with_unit(e.name, e.value, e.u, map.plane);
    const auto* before = find(v.before, e.name);
    const bool from_step = before && models::compensation::spike_from_backlash_step(map, *before, e);
    (from_step ? step : left) += ((from_step ? step : left).empty() ? " " : ", ") + text;
  }
  std::string out = "  still above 3 u after:" + (left.empty() ? std::string(" nothing") : left) + "\n";
  if (!step.empty())
    out += "  from the tables' backlash step, not the machine's stiction:" + step +
           " (the axis turns back early: the controller switches a table's backlash at the commanded reversal, "
           "while the drive still lags its command; velocity feed-forward or a reversal timing of the step removes "
           "it, no table does; docs/compensation.md)\n";
  return out;
}

std::string verification_text(const models::compensation::ErrorMap& map, const Verification& v,
                              const std::vector<Refusal>& refusals, nlohmann::json& j) {
  std::ostringstream o;
  const double g0 = largest(v.g_before), gt = largest(v.g_tables), gs = largest(v.g_skewed), g1 = largest(v.g_after);
  const auto stage = [&](double g, const char* what) {
    o << "\n    " << printf_number("%8.3f", g) << " \u00b5m (" << printf_number("%3.0f", 100 * g / g0) << " %)  "
      << what;
  };
  o << "\nverification on the virtual machine (the same test traced again):\n";
  o << "  circular deviation G:\n    " << printf_number("%8.3f", g0) << " \u00b5m          before";
  stage(gt, "with the tables");
  if (v.skew) stage(gs, "with the tables and the squareness as axis skew");
  if (v.cross)
    stage(g1, v.skew ? "with the tables, the axis skew and straightness.csv as cross-axis correction"
                     : "with the tables and straightness.csv as cross-axis correction");
  std::string all = "tables";
  if (v.skew) all += " + skew";
  if (v.cross) all += " + cross";
  o << "\n" << g_basis_text(v);
  std::vector<std::vector<std::string>> rows{{"term", "before", "after (" + all + ")", "|after|/u", ""}};
  j["g_before_um"] = g0;
  j["g_measured_before_um"] = v.g_before_measured;
  j["g_measured_after_um"] = v.g_after_measured;
  j["g_less"] = v.beside;
  j["g_tables_um"] = gt;
  j["g_tables_skew_um"] = gs;
  j["g_after_um"] = g1;
  j["skew_applied"] = v.skew;
  j["straightness_applied"] = v.cross;
  nlohmann::json terms = nlohmann::json::array();
  for (const auto& e : v.before.diagnostics) {
    if (!e.fitted || !std::isfinite(e.u) || e.name.rfind("run", 0) == 0 || e.name.rfind("center_offset", 0) == 0)
      continue;
    const auto* after = find(v.after, e.name);
    const bool seen = after && after->fitted && std::isfinite(after->u);
    const models::compensation::Term* t = nullptr;
    for (const auto& term : map.terms)
      if (term.name == e.name) t = &term;
    const double ratio = seen ? std::abs(after->value) / after->u : 0.0;
    const bool step = seen && models::compensation::spike_from_backlash_step(map, e, *after);
    const std::string status =
        step ? std::string(backlash_step_status) : (t ? term_status(*t, map, v, refusals, seen, ratio) : "");
    rows.push_back({results::label_of(e.name, map.plane), value_text(e, map, g0),
                    seen ? value_text(*after, map, g1) : "not detected", seen ? printf_number("%.1f", ratio) : "",
                    status});
    nlohmann::json tj = {{"name", e.name}, {"before", e.value}, {"before_u", e.u}, {"status", status}};
    if (seen) {
      tj["after"] = after->value;
      tj["after_u"] = after->u;
    }
    if (step) tj["from_backlash_step"] = true;
    terms.push_back(tj);
  }
  j["terms"] = terms;
  o << aligned_rows(rows, {false, true, true, true});
  o << left_after_text(map, v, g1);
  if (!v.written.empty())
    o << "  runs written to " << fs::path(v.written.front()).parent_path().string()
      << "/ (guideway report on them shows the polar plots before and after)\n";
  return o.str();
}

const models::dbb::Estimate* find_lai3(const models::dbb::Identification& id, const std::string& name) {
  for (const auto& e : id.lai3)
    if (e.name == name) return &e;
  return nullptr;
}

// A tilted-bar run (Lai's patterns) gives no diagnostics: the check compares each run's circular
// deviation G and Lai's parameters before and after.
std::string lai3_verification_text(const models::compensation::ErrorMap& map, const Verification& v,
                                   const std::vector<Refusal>& refusals, nlohmann::json& j) {
  std::ostringstream o;
  o << "\nverification on the virtual machine (each run traced again: radius, height, feed, direction;\n"
       "Lai's model, as the runs give no ballbar diagnostics):\n";
  o << "  run                                   G before    with the tables" << (v.skew ? "     + axis skew  " : "")
    << (v.cross ? "     + cross-axis" : "") << "\n";
  nlohmann::json runs = nlohmann::json::array();
  for (std::size_t k = 0; k < v.before.runs.size(); ++k) {
    const auto& b = v.before.runs[k];
    const double g0 = v.g_before.at(k), gt = v.g_tables.at(k), gs = v.g_skewed.at(k), g1 = v.g_after.at(k);
    const std::string name = printf_number("r %.3g mm", b.radius_mm) + printf_number(" h %.5g mm ", b.height_mm) +
                             b.direction + printf_number(" %.0f mm/min", b.feed_mm_per_min);
    o << "  " << name << std::string(name.size() < 38 ? 38 - name.size() : 1, ' ') << printf_number("%7.3f \u00b5m", g0)
      << printf_number("   %7.3f \u00b5m", gt) << printf_number(" (%3.0f %%)", 100 * gt / g0);
    if (v.skew) o << printf_number("  %7.3f \u00b5m", gs) << printf_number(" (%3.0f %%)", 100 * gs / g0);
    if (v.cross) o << printf_number("  %7.3f \u00b5m", g1) << printf_number(" (%3.0f %%)", 100 * g1 / g0);
    o << "\n";
    runs.push_back({{"radius_mm", b.radius_mm},
                    {"height_mm", b.height_mm},
                    {"direction", b.direction},
                    {"feed_mm_per_min", b.feed_mm_per_min},
                    {"g_before_um", g0},
                    {"g_tables_um", gt},
                    {"g_tables_skew_um", gs},
                    {"g_after_um", g1}});
  }
  j["model"] = "lai3";
  j["runs"] = runs;
  j["skew_applied"] = v.skew;
  j["straightness_applied"] = v.cross;
  o << g_basis_text(v);
  j["g_measured_before_um"] = v.g_before_measured;
  j["g_measured_after_um"] = v.g_after_measured;
  j["g_less"] = v.beside;
  std::vector<std::vector<std::string>> rows{{"Lai parameter", "before", "after (all corrections)", "|after|/u", ""}};
  nlohmann::json terms = nlohmann::json::array();
  std::string left;
  for (const auto& e : v.before.lai3) {
    if (!e.fitted || !std::isfinite(e.u) || e.name.starts_with("e_x") || e.name.starts_with("e_y") ||
        e.name == results::lai_mismatch_phase_angle.name)
      continue;
    const auto* after = find_lai3(v.after, e.name);
    const bool seen = after && after->fitted && std::isfinite(after->u);
    // S is a factor about 1: its error is S - 1.
    const double off = e.name.starts_with("S_") ? 1.0 : 0.0;
    const double ratio = seen ? std::abs(after->value - off) / after->u : 0.0;
    const std::string term = models::compensation::lai3_term_of(e.name, map.plane);
    const models::compensation::Term* t = nullptr;
    for (const auto& mt : map.terms)
      if (mt.name == term) t = &mt;
    std::string status;
    if (!t)
      status = "not in the map (out of plane or not separable)";
    else if (off != 0 && t->applied() && std::abs(t->value - (e.value - off) * 1e6) > 0.5)
      status = "tables hold the difference only (see the note; scale mismatch below)";
    else
      status = term_status(*t, map, v, refusals, seen, ratio);
    rows.push_back({results::label_of(e.name, map.plane, lai_group),
                    shown_with_unit(e.name, e.value, e.u, map.plane, lai_group),
                    seen ? shown_with_unit(e.name, after->value, after->u, map.plane, lai_group) : "not identified",
                    seen ? printf_number("%.1f", ratio) : "", status});
    if (seen && ratio > 3) left += (left.empty() ? " " : ", ") + results::label_of(e.name, map.plane, lai_group);
    nlohmann::json tj = {{"name", e.name}, {"before", e.value}, {"before_u", e.u}, {"status", status}};
    if (seen) {
      tj["after"] = after->value;
      tj["after_u"] = after->u;
    }
    terms.push_back(tj);
  }
  // The scale difference: what the tables correct when both scales share a radius change.
  const auto *sx0 = find_lai3(v.before, std::string(results::lai_S_x.name)),
             *sy0 = find_lai3(v.before, std::string(results::lai_S_y.name));
  const auto *sx1 = find_lai3(v.after, std::string(results::lai_S_x.name)),
             *sy1 = find_lai3(v.after, std::string(results::lai_S_y.name));
  if (sx0 && sy0 && sx1 && sy1) {
    // u of the difference without the two scales' correlation: an upper bound when they correlate positively.
    const double d0 = sx0->value - sy0->value, u0 = std::hypot(sx0->u, sy0->u);
    const double d1 = sx1->value - sy1->value, u1 = std::hypot(sx1->u, sy1->u);
    rows.push_back({"scale mismatch (S_x - S_y)", with_uncertainty(d0 * 1e6, u0 * 1e6) + " ppm",
                    with_uncertainty(d1 * 1e6, u1 * 1e6) + " ppm", printf_number("%.1f", std::abs(d1) / u1), ""});
    j["scale_mismatch_before"] = d0;
    j["scale_mismatch_after"] = d1;
    if (std::abs(d1) > 3 * u1) left += (left.empty() ? " " : ", ") + std::string("scale mismatch");
  }
  j["terms"] = terms;
  o << aligned_rows(rows, {false, true, true, true});
  o << "  still above 3 u after:" << (left.empty() ? std::string(" nothing") : left) << "\n";
  if (!v.written.empty())
    o << "  runs written to " << fs::path(v.written.front()).parent_path().string()
      << "/ (guideway report on them shows the polar plots before and after)\n";
  return o.str();
}

// Everything the command line lacks, said at once (not one option per attempt).
void require_options(const Opts& o) {
  std::vector<std::string> missing;
  if (o.files.empty() && !o.latest) missing.emplace_back("RUN.csv... or --latest (the runs to build the tables from)");
  if (o.out_dir.empty()) missing.emplace_back("--out-dir DIR (where the tables are written)");
  if (o.verify && o.machine.empty())
    missing.emplace_back("--machine FILE (--verify traces the test on the virtual machine of that file)");
  if (missing.empty()) return;
  std::string msg = "compensate dbb: missing ";
  for (std::size_t i = 0; i < missing.size(); ++i) msg += (i == 0 ? "" : "; ") + missing[i];
  throw std::runtime_error(msg);
}

// The map's terms as JSON: value, u (null when not determined), whether applied, and why not.
nlohmann::json terms_json(const models::compensation::ErrorMap& map) {
  namespace comp = models::compensation;
  nlohmann::json terms = nlohmann::json::array();
  for (const auto& t : map.terms)
    terms.push_back(
        {{"name", t.name},
         {"value", t.determined ? nlohmann::json(t.value) : nlohmann::json()},
         {"u", t.determined ? nlohmann::json(t.u) : nlohmann::json()},
         {"significant", t.significant},
         {"determined", t.determined},
         {"contradiction", t.contradiction},
         {"applied", t.applied()},
         {"use", t.use == comp::Use::table ? "table"
                                           : (t.use == comp::Use::map_only
                                                  ? "errors.csv"
                                                  : (t.use == comp::Use::cross_table ? "straightness.csv" : "none"))},
         {"why", t.why}});
  return terms;
}

// The axes to write tables for: --axes, each an axis the runs measured (`measured`: of the `plane` or
// planes), else all of them.
std::vector<std::string> table_axes(const std::string& wanted, const std::vector<std::string>& measured,
                                    const std::string& plane) {
  const std::vector<std::string>& both = measured;
  if (wanted.empty()) return both;
  std::vector<std::string> out;
  std::stringstream ss(wanted);
  for (std::string a; std::getline(ss, a, ',');) {
    if (std::find(both.begin(), both.end(), a) == both.end())
      throw std::runtime_error("compensate: --axes " + wanted + ": \"" + a + "\" is not an axis of the " + plane +
                               " the runs measured");
    out.push_back(a);
  }
  return out;
}

// Writes the files of `maps` (one plane's, or one per plane of a test in several) with the tables of `axes`
// only to o.out_dir, as one set; returns the paths written.
nlohmann::json write_compensation(const Opts& o, const std::vector<models::compensation::ErrorMap>& maps,
                                  const std::string& source, const std::vector<std::string>& axes,
                                  std::size_t all_axes) {
  fs::create_directories(o.out_dir);
  nlohmann::json written = nlohmann::json::array();
  std::vector<NamedContent> set;
  for (const auto& f : models::compensation::compensation_files(maps, source)) {
    const auto stem = f.name.substr(0, f.name.find('.'));
    if (f.name.ends_with(".comp") && std::find(axes.begin(), axes.end(), stem) == axes.end()) continue;
    std::string content = f.content;
    if (f.name == "linuxcnc.ini" && axes.size() != all_axes) {
      std::vector<formats::IniJoint> joints;
      for (const auto& a : axes) joints.push_back({models::compensation::joint_of(a), a, a + ".comp"});
      content = formats::format_linuxcnc_ini(joints, {"Guideway compensation, written from " + source});
    }
    set.push_back({f.name, std::move(content)});
    written.push_back((fs::path(o.out_dir) / f.name).string());
  }
  // One set or the other, never a mix: a table or a straightness.csv of an earlier compensation in this
  // directory would be loaded with these (a full disk half way leaves the earlier set whole).
  write_file_set_atomically(o.out_dir, set, models::compensation::compensation_file_names());
  return written;
}

// One map's terms and squareness as JSON.
void map_json(const models::compensation::ErrorMap& map, nlohmann::json& j) {
  j["plane"] = map.plane;
  j["model"] = map.model;
  j["notes"] = map.notes;
  j["step_mm"] = map.step_m * 1e3;
  j["terms"] = terms_json(map);
  if (map.squareness_known) {
    const auto adv = models::compensation::squareness_advice(map.squareness_rad);
    j["squareness"] = {{"urad", map.squareness_rad * 1e6},
                       {"u_urad", map.squareness_u_rad * 1e6},
                       {"um_per_m", adv.um_per_m},
                       {"correction_um_per_100mm", adv.correction_um_per_100mm},
                       {"significant", map.squareness_significant}};
  }
}

// The command's output, once its progress line is ended: the JSON for a program, else the text.
void print_output(const Opts& o, Progress& progress, const nlohmann::json& j, const std::string& text) {
  progress.doing("");
  if (o.json)
    std::cout << j.dump() << "\n";
  else
    std::cout << text;
}

// A test in several planes (the three-plane test): each plane identified and mapped as one plane is, each
// axis' scale and backlash the planes' combined figure (one table per axis; a figure its planes disagree
// on is refused), every plane's squareness as its axis skew; --verify retraces each plane's runs with the files.
void compensate_planes(const Opts& o, const std::vector<std::vector<formats::DbbRun>>& groups,
                       const std::string& source, Progress& progress) {
  namespace comp = models::compensation;
  if (!o.center_mm.empty())
    throw std::runtime_error(
        "compensate: --center-mm gives one plane's circle centre, and the runs are of several planes: each run "
        "file's centre metadata places its plane's circle");
  comp::MapOptions mo;
  mo.step_m = o.step_mm * 1e-3;
  std::vector<models::explain::CheckedIdentification> checked;
  std::vector<comp::ErrorMap> maps;
  std::vector<models::dbb::Identification> ids;
  std::vector<std::string> measured;
  std::string planes;
  for (const auto& g : groups) {
    planes += (planes.empty() ? "" : ", ") + g.front().plane;
    for (int k = 0; k < 2; ++k)
      if (const std::string a = results::axis_letter(g.front().plane, k);
          std::find(measured.begin(), measured.end(), a) == measured.end())
        measured.push_back(a);
  }
  const std::vector<std::string> axes = table_axes(o.axes, measured, planes + " planes");  // refused before the work
  for (const auto& g : groups) {
    progress.doing("identifying the " + g.front().plane + " plane's runs, with what EXPLAIN finds fitted beside");
    try {
      comp::check_map_inputs(g, mo);
      checked.push_back(models::explain::identify_checked(g));
      maps.push_back(comp::error_map(checked.back(), g, mo));
    } catch (const comp::CompensationError& e) {
      throw std::runtime_error("compensate: the " + g.front().plane + " plane: " + e.what());
    }
    ids.push_back(checked.back().id);
  }
  const std::vector<comp::RefusedFigure> refused_figures =
      comp::use_machine_figures(maps, models::dbb::summarize_planes(ids));
  nlohmann::json j;
  j["planes"] = nlohmann::json::array();
  j["files"] = write_compensation(o, maps, source, axes, measured.size());
  std::string text;
  for (const auto& m : maps) {
    nlohmann::json pj;
    map_json(m, pj);
    j["planes"].push_back(pj);
    text += "== " + m.plane + " plane ==\n" + comp::to_text(m);
  }
  j["refused_figures"] = nlohmann::json::array();
  for (const auto& r : refused_figures) {
    text += "NOT WRITTEN: " + r.name + " (in " + r.axis + ".comp), its planes disagree: " + r.why + "\n";
    j["refused_figures"].push_back({{"name", r.name}, {"axis", r.axis}, {"why", r.why}});
  }
  for (const auto& p : j["files"]) text += "wrote " + p.get<std::string>() + "\n";
  if (o.verify) {
    std::vector<Verification> vs;
    nlohmann::json vj;
    vj["planes"] = nlohmann::json::array();
    const auto machine = simulators::machine::load_machine_config(o.machine);
    std::vector<comp::Retrace> retraces;
    for (std::size_t i = 0; i < maps.size(); ++i) {
      std::vector<std::string> plane_axes;
      for (const auto& am : maps[i].axes)
        if (std::find(axes.begin(), axes.end(), am.axis) != axes.end()) plane_axes.push_back(am.axis);
      progress.doing("verify: the " + maps[i].plane + " plane's test traced again on " + o.machine +
                     " without and with the files, and identified");
      retraces.push_back(simulators::machine::dbb_retrace(machine, groups[i]));
      vs.push_back(comp::verify(groups[i], checked[i], maps[i], o.out_dir, plane_axes, retraces.back()));
      comp::write_verify_runs(vs.back(), fs::path(o.out_dir) / "verify" / maps[i].plane);
    }
    progress.doing("verify: the planes traced again with what all of them leave fit to load");
    const Verification all = comp::together(maps, vs, retraces);
    for (std::size_t i = 0; i < vs.size(); ++i) {
      // The plane's terms said with what the planes together refuse: its own skew, and any plane's files.
      std::vector<Refusal> refusals = vs[i].refused;
      for (const auto& r : all.refused)
        if (r.file != "axis skew" && !refused(refusals, r.file)) refusals.push_back(r);
      nlohmann::json pj;
      text += "\n== " + maps[i].plane + " plane ==" +
              (maps[i].model == "lai3" ? lai3_verification_text(maps[i], vs[i], refusals, pj)
                                       : verification_text(maps[i], vs[i], refusals, pj));
      pj["plane"] = maps[i].plane;
      pj["loadable"] = vs[i].loadable;  // each plane's G with the union's set
      pj["g_loadable_um"] = vs[i].g_loadable;
      pj["g_before_runs_um"] = vs[i].g_before;
      vj["planes"].push_back(pj);
    }
    text += "\nthe planes together:\n";
    text += mark_refused(all, planes, o.out_dir, axes, source, vj);
    j["verify"] = vj;
  }
  print_output(o, progress, j, text);
}

void run_compensate(const Opts& o, const std::string& socket) {
  require_options(o);
  std::vector<std::string> files = o.files;
  std::string source;
  if (o.latest) {
    if (!files.empty()) throw std::runtime_error("compensate: give run files or --latest, not both");
    std::string session;
    files = latest_session_runs(socket, session);
    source = "session " + session;
  }
  if (files.empty()) throw std::runtime_error("compensate: no run files (give RUN.csv... or --latest)");
  std::vector<formats::DbbRun> runs;
  for (const auto& f : files) runs.push_back(formats::read_dbb_run(f));
  if (source.empty()) {
    for (const auto& f : files) source += (source.empty() ? "" : ", ") + fs::path(f).filename().string();
  }
  Progress progress("compensate", o.quiet || o.json);
  if (auto groups = models::dbb::runs_by_plane(runs); groups.size() > 1) {
    compensate_planes(o, groups, source, progress);
    return;
  }
  models::compensation::MapOptions mo;
  if (o.center_mm.size() == 2) {
    mo.center_m = std::array<double, 2>{o.center_mm[0] * 1e-3, o.center_mm[1] * 1e-3};
    // The cyclic error's phase is fitted in machine coordinates: the runs need the centre too.
    for (auto& r : runs) {
      r.center_a_m = (*mo.center_m)[0];
      r.center_b_m = (*mo.center_m)[1];
    }
  }
  mo.step_m = o.step_mm * 1e-3;
  const std::string plane = runs.front().plane;
  const std::vector<std::string> axes =
      table_axes(o.axes, {results::axis_letter(plane, 0), results::axis_letter(plane, 1)}, plane + " plane");
  models::compensation::ErrorMap map;
  models::explain::CheckedIdentification checked;
  try {
    models::compensation::check_map_inputs(runs, mo);  // bad input refused before the identification's work
    // The identification with what EXPLAIN finds on the same runs fitted beside, and its values to check
    // the terms against.
    progress.doing("identifying the runs, with what EXPLAIN finds fitted beside");
    checked = models::explain::identify_checked(runs);
    map = models::compensation::error_map(checked, runs, mo);
  } catch (const models::compensation::CompensationError& e) {
    throw std::runtime_error(std::string("compensate: ") + e.what());
  }
  nlohmann::json j;
  map_json(map, j);
  j["files"] = write_compensation(o, {map}, source, axes, map.axes.size());
  std::string text = models::compensation::to_text(map);
  for (const auto& p : j["files"]) text += "wrote " + p.get<std::string>() + "\n";
  if (o.verify) {
    progress.doing("verify: the test traced again on " + o.machine + " without and with the files, and identified");
    const auto machine = simulators::machine::load_machine_config(o.machine);
    Verification v = models::compensation::verify(runs, checked, map, o.out_dir, axes,
                                                  simulators::machine::dbb_retrace(machine, runs));
    models::compensation::write_verify_runs(v, fs::path(o.out_dir) / "verify");
    const std::vector<Refusal>& refuse = v.refused;
    nlohmann::json vj;
    text += map.model == "lai3" ? lai3_verification_text(map, v, refuse, vj) : verification_text(map, v, refuse, vj);
    text += mark_refused(v, map.plane, o.out_dir, axes, source, vj);
    j["verify"] = vj;
  }
  print_output(o, progress, j, text);
}

// CLI11 reads "nan" and "inf" as numbers: a table position or step must be a finite one.
const CLI::Validator finite_number(
    [](std::string& text) {
      char* end = nullptr;
      const double v = std::strtod(text.c_str(), &end);
      return std::isfinite(v) ? std::string() : "\"" + text + "\" is not a finite number";
    },
    "FINITE");

void add_compensate_commands(CLI::App& app, CliContext& ctx) {
  auto* cmd = shared_subcommand(app, "compensate", "Compensation tables from identified machine errors (docs/compensation.md)");
  auto* d = cmd->add_subcommand("dbb", "LinuxCNC per-joint tables, INI lines and errors.csv from DBB runs");
  auto o = std::make_shared<Opts>();
  d->add_option("runs", o->files, "DBB run files (guideway/dbb-run/1): in-plane circles in both directions")
      ->check(CLI::ExistingFile);
  d->add_flag("--latest", o->latest, "the run files of the daemon's latest DBB session instead of files");
  // Required, but checked with the other missing options (require_options) so all are named at once.
  d->add_option("--out-dir", o->out_dir,
                "directory for x.comp, y.comp, linuxcnc.ini, errors.csv, straightness.csv (required)");
  d->add_option("--center-mm", o->center_mm,
                "circle centre in machine coordinates (first, second plane axis); default: the runs' metadata")
      ->expected(2)
      ->check(finite_number);
  d->add_option("--axes", o->axes, "tables for these plane axes only, e.g. x (default: both)");
  d->add_option("--step-mm", o->step_mm, "table spacing (default: the finest round step within 256 lines)")
      ->check(finite_number & CLI::PositiveNumber);
  d->add_flag("--json", o->json, "print the result as one JSON object");
  d->add_flag("--quiet", o->quiet, "no progress lines on standard error (--json: none either)");
  d->add_flag("--verify", o->verify,
              "trace the same test on the virtual machine without and with the tables and print before/after");
  d->add_option("--machine", o->machine, "with --verify: the machine file (docs/machine.md)")->check(CLI::ExistingFile);
  d->callback([o, &ctx] { run_compensate(*o, ctx.socket); });
  cmd->require_subcommand(1);
}

const CommandGroup group(&add_compensate_commands);

}  // namespace

}  // namespace guideway::cli
