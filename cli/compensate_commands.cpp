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
#include "core/atomic_file.hpp"
#include "core/number_format.hpp"
#include "formats/compensation_files.hpp"
#include "models/compensation/compensation.hpp"
#include "models/dbb/identify.hpp"
#include "results/parameters.hpp"
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
  bool json = false, verify = false, latest = false;
};

const models::dbb::Estimate* find(const models::dbb::Identification& id, const std::string& name) {
  for (const auto& e : id.diagnostics)
    if (e.name == name) return &e;
  return nullptr;
}

double circular_deviation_um(const models::dbb::Identification& id) {
  const auto* g = find(id, results::name(results::circular_deviation));
  return g ? g->value : NAN;
}

// The run files of the daemon's latest DBB session (its PARAMS' derived files).
std::vector<std::string> latest_session_runs(const std::string& socket, std::string& session) {
  DaemonClient c = connect_daemon(socket);
  const nlohmann::json r =
      c.request(results::request(results::RequestClass::params, {{"kind", results::dbb_kind.name}}),
                results::MessageClass::params);
  throw_if_error(r);
  session = r.value("session", std::string("latest session"));
  std::vector<std::string> out;
  if (r.contains("derived"))
    for (const auto& p : r.at("derived")) {
      const std::string path = p.get<std::string>();
      if (fs::path(path).extension() == ".csv") out.push_back(path);
    }
  if (out.empty())
    throw std::runtime_error("compensate: the daemon's latest DBB session (" + session +
                             ") left no run files (was it recorded?); give the run files instead");
  return out;
}

// A value as people read it, with its unit: "-10.71 ± 0.18 ppm" (results::shown).
std::string shown_with_unit(const std::string& name, double value, double u, const std::string& plane,
                            std::string_view group = {}) {
  const results::Shown s = results::shown(name, value, u, plane, group);
  return s.value + (s.unit.empty() ? "" : " " + s.unit);
}

// Lai's group in the catalogue: its "backlash_y_um" is the plane's second axis.
constexpr std::string_view lai_group = results::lai_S_x.group;

struct Verification {
  // Before; with the tables; with the tables and the squareness as axis skew; with those and the
  // straightness as the cross-axis correction (`after`: everything the files and the advice correct).
  models::dbb::Identification before, tables, skewed, after;
  bool skew = false;   // the squareness was significant and entered as the controller's axis skew
  bool cross = false;  // straightness.csv was written and loaded
  std::vector<std::string> written;
};

// Traces every run's test on the virtual machine: as it is, with the tables written to `out_dir` (read
// back from the files, as the controller would), then adding the squareness as the axis-skew correction
// the user is told to enter, then the cross-axis correction of straightness.csv. Writes the runs before
// and with every correction to out_dir/verify/.
Verification verify(const std::vector<formats::DbbRun>& runs, const models::compensation::ErrorMap& map,
                    const std::string& machine_file, const std::string& out_dir, const std::vector<std::string>& axes) {
  const simulators::machine::MachineConfig config = simulators::machine::load_machine_config(machine_file);
  simulators::machine::ControllerCorrection tables;
  for (const auto& axis : axes)
    tables.tables[static_cast<std::size_t>(models::compensation::joint_of(axis))] =
        simulators::machine::joint_compensation(
            formats::read_linuxcnc_comp((fs::path(out_dir) / (axis + ".comp")).string()));
  simulators::machine::Vec3 center{};
  center[static_cast<std::size_t>(models::compensation::joint_of(map.axes[0].axis))] = map.terms_of[0].center_m;
  center[static_cast<std::size_t>(models::compensation::joint_of(map.axes[1].axis))] = map.terms_of[1].center_m;
  Verification v;
  simulators::machine::ControllerCorrection skewed = tables;
  if (map.squareness_known && map.squareness_significant) {
    v.skew = true;
    (map.plane == "xy" ? skewed.skew.xy : (map.plane == "xz" ? skewed.skew.xz : skewed.skew.yz)) = map.squareness_rad;
  }
  simulators::machine::ControllerCorrection full = skewed;
  const fs::path straightness = fs::path(out_dir) / "straightness.csv";
  if (fs::exists(straightness)) {
    v.cross = true;
    full.cross = simulators::machine::cross_compensation(formats::read_straightness_csv(straightness.string()));
  }
  const simulators::machine::RemeasuredRuns r = simulators::machine::remeasure_dbb(config, full, runs, center);
  v.before = models::dbb::identify(r.before);
  v.after = models::dbb::identify(r.after);
  v.skewed =
      v.cross ? models::dbb::identify(simulators::machine::remeasure_dbb(config, skewed, runs, center).after) : v.after;
  v.tables =
      v.skew ? models::dbb::identify(simulators::machine::remeasure_dbb(config, tables, runs, center).after) : v.skewed;
  const fs::path dir = fs::path(out_dir) / "verify";
  fs::create_directories(dir);
  // Runs of an earlier check with more runs would otherwise join this one's in a report of the directory.
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() == ".csv" && (name.starts_with("before_") || name.starts_with("after_")))
      fs::remove(entry.path());
  }
  for (const auto* list : {&r.before, &r.after})
    for (const auto& run : *list) {
      const std::string path = (dir / (run.source + ".csv")).string();
      formats::write_dbb_run(run, path);
      v.written.push_back(path);
    }
  return v;
}

std::string verification_text(const models::compensation::ErrorMap& map, const Verification& v, nlohmann::json& j) {
  std::ostringstream o;
  const double g0 = circular_deviation_um(v.before), gt = circular_deviation_um(v.tables),
               gs = circular_deviation_um(v.skewed), g1 = circular_deviation_um(v.after);
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
  o << "\n";
  std::vector<std::vector<std::string>> rows{{"term", "before", "after (" + all + ")", "|after|/u", ""}};
  j["g_before_um"] = g0;
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
    std::string status;
    if (t && t->use == models::compensation::Use::table && t->significant)
      status = !seen ? "compensated (no longer detected)"
                     : (ratio < 3 ? "compensated (< 3 u)" : "compensated, NOT below 3 u");
    else if (t && e.name == results::squareness.name)
      status = v.skew ? "axis skew (not a per-joint table)" : "not applied (not significant)";
    else if (t && t->significant && t->use == models::compensation::Use::cross_table)
      status = v.cross ? "cross-axis correction (straightness.csv)" : "not applied";
    else if (t && t->significant)
      status = t->use == models::compensation::Use::map_only ? "no per-joint table can hold it (errors.csv)"
                                                             : "servo/friction: no table";
    else if (t)
      status = "not applied (not significant)";
    rows.push_back({results::label_of(e.name, map.plane), shown_with_unit(e.name, e.value, e.u, map.plane),
                    seen ? shown_with_unit(e.name, after->value, after->u, map.plane) : "not detected",
                    seen ? printf_number("%.1f", ratio) : "", status});
    nlohmann::json tj = {{"name", e.name}, {"before", e.value}, {"before_u", e.u}, {"status", status}};
    if (seen) {
      tj["after"] = after->value;
      tj["after_u"] = after->u;
    }
    terms.push_back(tj);
  }
  j["terms"] = terms;
  o << aligned_rows(rows, {false, true, true, true});
  std::string left;
  for (const auto& e : v.after.diagnostics)
    if (e.fitted && std::isfinite(e.u) && std::abs(e.value) > 3 * e.u && e.name.rfind("run", 0) != 0 &&
        e.name.rfind("center_offset", 0) != 0 && e.name.rfind("circular_", 0) != 0)
      left += (left.empty() ? " " : ", ") + results::label_of(e.name, map.plane) + " " +
              shown_with_unit(e.name, e.value, e.u, map.plane);
  o << "  still above 3 u after:" << (left.empty() ? std::string(" nothing") : left) << "\n";
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
                                   nlohmann::json& j) {
  std::ostringstream o;
  o << "\nverification on the virtual machine (each run traced again: radius, height, feed, direction;\n"
       "Lai's model, as the runs give no ballbar diagnostics):\n";
  o << "  run                                   G before    with the tables" << (v.skew ? "     + axis skew  " : "")
    << (v.cross ? "     + cross-axis" : "") << "\n";
  nlohmann::json runs = nlohmann::json::array();
  for (std::size_t k = 0; k < v.before.runs.size(); ++k) {
    const auto& b = v.before.runs[k];
    const double g0 = b.circular_deviation_um, gt = v.tables.runs.at(k).circular_deviation_um,
                 gs = v.skewed.runs.at(k).circular_deviation_um, g1 = v.after.runs.at(k).circular_deviation_um;
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
    else if (off != 0 && t->significant && std::abs(t->value - (e.value - off) * 1e6) > 0.5)
      status = "tables hold the difference only (see the note; scale mismatch below)";
    else if (t->use == models::compensation::Use::table && t->significant)
      status = ratio < 3 ? "compensated (< 3 u)" : "compensated, NOT below 3 u";
    else if (term == results::squareness.name)
      status = v.skew ? "axis skew (not a per-joint table)" : "not applied (not significant)";
    else if (t->use == models::compensation::Use::cross_table && t->significant)
      status = v.cross ? "cross-axis correction (straightness.csv)" : "not applied";
    else if (t->significant)
      status = t->use == models::compensation::Use::map_only ? "no per-joint table can hold it (errors.csv)"
                                                             : "servo: no table";
    else
      status = "not applied (not significant)";
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
  const models::dbb::Identification id = models::dbb::identify(runs);
  models::compensation::ErrorMap map;
  try {
    map = models::compensation::error_map(id, runs, mo);
  } catch (const models::compensation::CompensationError& e) {
    throw std::runtime_error(std::string("compensate: ") + e.what());
  }
  std::vector<std::string> axes;
  for (const auto& am : map.axes) axes.push_back(am.axis);
  if (!o.axes.empty()) {
    std::vector<std::string> wanted;
    std::stringstream ss(o.axes);
    for (std::string a; std::getline(ss, a, ',');) {
      if (std::find(axes.begin(), axes.end(), a) == axes.end())
        throw std::runtime_error("compensate: --axes " + o.axes + ": \"" + a + "\" is not an axis of the " + map.plane +
                                 " plane the runs measured");
      wanted.push_back(a);
    }
    axes = wanted;
  }
  fs::create_directories(o.out_dir);
  nlohmann::json j;
  j["plane"] = map.plane;
  j["model"] = map.model;
  j["notes"] = map.notes;
  j["step_mm"] = map.step_m * 1e3;
  nlohmann::json written = nlohmann::json::array();
  std::vector<NamedContent> set;
  for (const auto& f : models::compensation::compensation_files(map, source)) {
    const auto stem = f.name.substr(0, f.name.find('.'));
    if (f.name.ends_with(".comp") && std::find(axes.begin(), axes.end(), stem) == axes.end()) continue;
    std::string content = f.content;
    if (f.name == "linuxcnc.ini" && axes.size() != map.axes.size()) {
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
  j["files"] = written;
  nlohmann::json terms = nlohmann::json::array();
  for (const auto& t : map.terms)
    terms.push_back(
        {{"name", t.name},
         {"value", t.value},
         {"u", t.u},
         {"significant", t.significant},
         {"use", t.use == models::compensation::Use::table
                     ? "table"
                     : (t.use == models::compensation::Use::map_only
                            ? "errors.csv"
                            : (t.use == models::compensation::Use::cross_table ? "straightness.csv" : "none"))},
         {"why", t.why}});
  j["terms"] = terms;
  if (map.squareness_known) {
    const auto adv = models::compensation::squareness_advice(map.squareness_rad);
    j["squareness"] = {{"urad", map.squareness_rad * 1e6},
                       {"u_urad", map.squareness_u_rad * 1e6},
                       {"um_per_m", adv.um_per_m},
                       {"correction_um_per_100mm", adv.correction_um_per_100mm},
                       {"significant", map.squareness_significant}};
  }
  std::string text = models::compensation::to_text(map);
  for (const auto& p : written) text += "wrote " + p.get<std::string>() + "\n";
  if (o.verify) {
    const Verification v = verify(runs, map, o.machine, o.out_dir, axes);
    nlohmann::json vj;
    text += map.model == "lai3" ? lai3_verification_text(map, v, vj) : verification_text(map, v, vj);
    j["verify"] = vj;
  }
  if (o.json)
    std::cout << j.dump() << "\n";
  else
    std::cout << text;
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
  auto* cmd =
      app.add_subcommand("compensate", "Compensation tables from identified machine errors (docs/compensation.md)");
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
  d->add_flag("--verify", o->verify,
              "trace the same test on the virtual machine without and with the tables and print before/after");
  d->add_option("--machine", o->machine, "with --verify: the machine file (docs/machine.md)")->check(CLI::ExistingFile);
  d->callback([o, &ctx] { run_compensate(*o, ctx.socket); });
  cmd->require_subcommand(1);
}

const CommandGroup group(&add_compensate_commands);

}  // namespace

}  // namespace guideway::cli
