// The verification of a compensation on a virtual machine handed in as a Retrace (verification.hpp).
#include "models/compensation/verification.hpp"

#include <algorithm>
#include <functional>
#include <limits>

#include "core/atomic_file.hpp"
#include "core/input_file.hpp"
#include "core/number_format.hpp"
#include "formats/compensation_files.hpp"
#include "models/dbb/identify.hpp"

namespace guideway::models::compensation {

namespace fs = std::filesystem;

std::vector<double> g_of_runs(const std::vector<formats::DbbRun>& runs, const std::vector<double>& less_um) {
  std::size_t total = 0;
  for (const auto& run : runs) total += run.dL_m.size();
  const bool less = less_um.size() == total;
  std::vector<double> out;
  std::size_t i0 = 0;
  for (const auto& run : runs) {
    std::vector<double> um(run.dL_m.size());
    for (std::size_t i = 0; i < um.size(); ++i) um[i] = run.dL_m[i] * 1e6 - (less ? less_um[i0 + i] : 0.0);
    out.push_back(dbb::range_about_circle(run.angle_rad, um));
    i0 += um.size();
  }
  return out;
}

namespace {

// A run as the verification names it: "run 2 (r 95 mm h 31.225 mm ccw 5003 mm/min)".
std::string run_label(const dbb::Identification& id, std::size_t k) {
  const auto& b = id.runs.at(k);
  return "run " + std::to_string(k + 1) + " (" + printf_number("r %.3g mm", b.radius_mm) +
         printf_number(" h %.5g mm ", b.height_mm) + b.direction + printf_number(" %.0f mm/min", b.feed_mm_per_min) +
         ")";
}

}  // namespace

std::vector<Refusal> refuse_growth(
    const std::vector<double>& g_before, std::vector<const Correction*>& set, std::vector<double>& g,
    const std::function<std::vector<double>(const std::vector<const Correction*>&)>& g_of,
    const std::function<std::string(std::size_t)>& run_label) {
  // Larger means more than the printed resolution (1 nm): the retraces reuse each run's noise, so a
  // difference is the corrections'.
  constexpr double tolerance_um = 5e-4;
  const auto worst = [&](const std::vector<double>& gs) {  // the run grown most (ratio), gs.size() for none
    std::size_t w = gs.size();
    for (std::size_t k = 0; k < gs.size() && k < g_before.size(); ++k)
      if (gs[k] > g_before[k] + tolerance_um && (w == gs.size() || gs[k] / g_before[k] > gs[w] / g_before[w])) w = k;
    return w;
  };
  std::vector<Refusal> out;
  for (std::size_t k = worst(g); !set.empty() && k < g.size(); k = worst(g)) {
    std::size_t drop = 0;
    std::vector<double> g_drop;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < set.size(); ++i) {
      std::vector<const Correction*> rest = set;
      rest.erase(rest.begin() + static_cast<std::ptrdiff_t>(i));
      std::vector<double> gi = rest.empty() ? g_before : g_of(rest);
      const std::size_t wi = worst(gi);
      const double growth = wi < gi.size() ? gi[wi] / g_before[wi] : 0.0;
      if (i == 0 || growth < best) {
        best = growth;
        drop = i;
        g_drop = std::move(gi);
      }
    }
    std::string with;
    for (const Correction* c : set) with += (with.empty() ? "" : " + ") + c->file;
    out.push_back({set[drop]->file,
                   "with " + with + " loaded, G of " + run_label(k) + " grows from " +
                       printf_number("%.3f", g_before[k]) + " to " + printf_number("%.3f um", g[k]) +
                       (g_before[k] > 0 ? printf_number(" (%.0f %%)", 100 * g[k] / g_before[k]) : std::string())});
    set.erase(set.begin() + static_cast<std::ptrdiff_t>(drop));
    g = std::move(g_drop);
  }
  return out;
}

Verification verify(const std::vector<formats::DbbRun>& runs, const explain::CheckedIdentification& checked,
                    const ErrorMap& map, const std::string& out_dir, const std::vector<std::string>& axes,
                    const Retrace& retrace) {
  std::vector<Correction> all;
  for (const auto& axis : axes)
    all.push_back({axis + ".comp", Correction::Kind::table, (fs::path(out_dir) / (axis + ".comp")).string(),
                   joint_of(axis), "", 0.0});
  const std::size_t n_tables = all.size();
  std::array<double, 3> center{};
  center[static_cast<std::size_t>(joint_of(map.axes[0].axis))] = map.terms_of[0].center_m;
  center[static_cast<std::size_t>(joint_of(map.axes[1].axis))] = map.terms_of[1].center_m;
  Verification v;
  if (map.squareness_known && map.squareness_significant) {
    v.skew = true;
    all.push_back({"axis skew", Correction::Kind::skew, "", 0, map.plane, map.squareness_rad});
  }
  if (const fs::path straightness = fs::path(out_dir) / "straightness.csv"; fs::exists(straightness)) {
    v.cross = true;
    all.push_back({"straightness.csv", Correction::Kind::cross, straightness.string(), 0, "", 0.0});
  }
  std::vector<const Correction*> tables, skewed, full;
  for (const auto& c : all) full.push_back(&c);
  tables.assign(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(n_tables));
  skewed.assign(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(n_tables + (v.skew ? 1 : 0)));
  auto [runs_before, runs_after] = retrace.before_and_after(full, center);
  // Identified as the runs were; the retraces of simulated runs share their sample grid, and the retrace
  // after the retrace before, so EXPLAIN's findings are reused there (identify_checked_like).
  const explain::CheckedIdentification before = explain::identify_checked_like(runs_before, checked, runs);
  v.before = before.id;
  v.beside = before.beside;
  v.after = explain::identify_checked_like(runs_after, before, runs_before).id;
  const std::vector<double>& less = before.beside_um;
  const auto g_of = [&](const std::vector<const Correction*>& set) {
    return g_of_runs(retrace.with(set, center), less);
  };
  v.g_before = g_of_runs(runs_before, less);
  v.g_after = g_of_runs(runs_after, less);
  v.g_before_measured = g_of_runs(runs_before);
  v.g_after_measured = g_of_runs(runs_after);
  v.g_skewed = v.cross ? g_of(skewed) : v.g_after;
  v.g_tables = v.skew ? g_of(tables) : v.g_skewed;
  std::vector<const Correction*> fit = full;
  std::vector<double> g_fit = v.g_after;  // every correction loaded
  v.refused = refuse_growth(v.g_before, fit, g_fit, g_of, [&](std::size_t k) { return run_label(v.before, k); });
  for (const Correction* c : fit) v.loadable.push_back(c->file);
  if (v.refused.empty()) {
    v.g_loadable = v.g_after;
    v.g_loadable_measured = v.g_after_measured;
  } else if (!fit.empty()) {
    const auto traced = retrace.with(fit, center);
    v.g_loadable = g_of_runs(traced, less);
    v.g_loadable_measured = g_of_runs(traced);
  }
  v.runs_before = std::move(runs_before);
  v.runs_after = std::move(runs_after);
  v.corrections = std::move(all);
  v.center_m = center;
  v.less_um = less;
  return v;
}

void write_verify_runs(Verification& v, const fs::path& dir) {
  fs::create_directories(dir);
  // Runs of an earlier check with more runs would otherwise join this one's in a report of the directory.
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() == ".csv" && (name.starts_with("before_") || name.starts_with("after_")))
      fs::remove(entry.path());
  }
  for (const auto* list : {&v.runs_before, &v.runs_after})
    for (const auto& run : *list) {
      const std::string path = (dir / (run.source + ".csv")).string();
      formats::write_dbb_run(run, path);
      v.written.push_back(path);
    }
}

bool refused(const std::vector<Refusal>& list, const std::string& file) {
  return std::any_of(list.begin(), list.end(), [&](const Refusal& r) { return r.file == file; });
}

Verification merged(const std::vector<ErrorMap>& maps, const std::vector<Verification>& vs) {
  Verification all;
  bool same = true;
  for (std::size_t i = 0; i < vs.size(); ++i)
    for (const auto& r : vs[i].refused)
      if (r.file == "axis skew" || !refused(all.refused, r.file))
        all.refused.push_back({r.file, "the " + maps[i].plane + " plane: " + r.why});
  for (const auto& v : vs) {
    for (const auto& f : v.loadable)
      if (refused(all.refused, f)) same = false;
    for (const auto& e : v.beside)
      if (std::find(all.beside.begin(), all.beside.end(), e) == all.beside.end()) all.beside.push_back(e);
    all.g_before.insert(all.g_before.end(), v.g_before.begin(), v.g_before.end());
    all.g_before_measured.insert(all.g_before_measured.end(), v.g_before_measured.begin(), v.g_before_measured.end());
    all.g_loadable.insert(all.g_loadable.end(), v.g_loadable.begin(), v.g_loadable.end());
    all.g_loadable_measured.insert(all.g_loadable_measured.end(), v.g_loadable_measured.begin(),
                                   v.g_loadable_measured.end());
    for (const auto& f : v.loadable)
      if (f != "axis skew" && std::find(all.loadable.begin(), all.loadable.end(), f) == all.loadable.end())
        all.loadable.push_back(f);
  }
  const bool skews = std::any_of(vs.begin(), vs.end(), [](const Verification& v) {
    return std::find(v.loadable.begin(), v.loadable.end(), "axis skew") != v.loadable.end();
  });
  if (skews) all.loadable.emplace_back("the planes' axis skews");
  if (!same || all.g_loadable.size() != all.g_before.size()) all.g_loadable.clear();
  return all;
}

Verification together(const std::vector<ErrorMap>& maps, std::vector<Verification>& vs,
                      const std::vector<Retrace>& retraces) {
  // A plane's skew is its own; a file refused in any plane is refused in all.
  const auto union_refuses = [&](std::size_t i, const std::string& file) {
    if (file == "axis skew") return refused(vs[i].refused, file);
    return std::any_of(vs.begin(), vs.end(), [&](const Verification& v) { return refused(v.refused, file); });
  };
  for (bool changed = true; changed;) {
    changed = false;
    for (std::size_t i = 0; i < vs.size(); ++i) {
      Verification& v = vs[i];
      std::vector<const Correction*> set;
      std::vector<std::string> files;
      for (const auto& c : v.corrections)
        if (!union_refuses(i, c.file)) {
          set.push_back(&c);
          files.push_back(c.file);
        }
      if (files == v.loadable) continue;  // traced with this set already
      const auto traced = [&](const std::vector<const Correction*>& s) { return retraces[i].with(s, v.center_m); };
      const auto g_of = [&](const std::vector<const Correction*>& s) { return g_of_runs(traced(s), v.less_um); };
      std::vector<double> g = set.empty() ? v.g_before : g_of(set);
      for (auto& r : refuse_growth(v.g_before, set, g, g_of, [&](std::size_t k) { return run_label(v.before, k); })) {
        r.why = "with the other planes' refusals, " + r.why;
        v.refused.push_back(std::move(r));
        changed = true;
      }
      v.loadable.clear();
      for (const Correction* c : set) v.loadable.push_back(c->file);
      v.g_loadable = set.empty() ? v.g_before : g;
      v.g_loadable_measured = set.empty() ? v.g_before_measured : g_of_runs(traced(set));
    }
  }
  return merged(maps, vs);
}

std::vector<AppliedRefusal> apply_refusals(const Verification& v, const std::string& out_dir,
                                           const std::vector<std::string>& axes, const std::string& source) {
  const std::vector<Refusal>& list = v.refused;
  std::vector<AppliedRefusal> out;
  if (list.empty()) return out;
  std::vector<NamedContent> set;
  std::vector<std::string> retired;
  for (const auto& r : list) {
    const fs::path path = fs::path(out_dir) / r.file;
    std::string renamed;
    if (r.file != "axis skew" && fs::exists(path)) {
      renamed = path.string() + std::string(do_not_load_suffix);
      set.push_back({r.file + std::string(do_not_load_suffix), read_text_file(path.string())});
      retired.push_back(r.file);
    }
    out.push_back({r.file, r.why, renamed});
  }
  std::vector<formats::IniJoint> joints;
  for (const auto& a : axes)
    if (!refused(list, a + ".comp")) joints.push_back({joint_of(a), a, a + ".comp"});
  std::vector<std::string> comments{"Guideway compensation from " + source + ": lines for the [JOINT_n] sections"};
  for (const auto& r : list) comments.push_back("NOT LOADED: " + r.file + ", refused by the verification: " + r.why);
  set.push_back({"linuxcnc.ini", formats::format_linuxcnc_ini(joints, comments)});
  // One set: the refused files under their new names and the INI that no longer loads them, or nothing.
  write_file_set_atomically(out_dir, set, retired);
  return out;
}

}  // namespace guideway::models::compensation
