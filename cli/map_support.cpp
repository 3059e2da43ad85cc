// What the `guideway map` and `guideway compensate map` commands share (map_support.hpp).
#include "cli/map_support.hpp"

#include <cmath>
#include <filesystem>
#include <iostream>

#include "cli/daemon_client.hpp"
#include "cli/params_print.hpp"
#include "core/atomic_file.hpp"
#include "core/number_format.hpp"
#include "models/map/day.hpp"
#include "models/map/exports.hpp"
#include "models/map/map_json.hpp"
#include "report/report.hpp"
#include "results/message_class.hpp"
#include "results/result_header.hpp"
#include "results/session_kinds.hpp"

namespace guideway::cli {

namespace {

namespace fs = std::filesystem;
namespace mm = models::map;

std::string pm(double value, double u, const std::string& unit) {
  if (!std::isfinite(u) || !(u > 0)) return format_number(value, 4) + " " + unit;
  return with_uncertainty(value, u) + " " + unit;
}

}  // namespace

void add_file_inputs(mm::MapInputs& in, const std::vector<std::string>& dbb, const std::vector<std::string>& traverses,
                     const std::vector<std::string>& artifacts, const mm::Vec3& other,
                     const std::vector<std::string>& runouts) {
  for (const auto& f : dbb) in.ballbar_runs.push_back(formats::read_dbb_run(f));
  for (const auto& f : traverses) in.traverses.push_back(mm::read_traverse_test(f));
  for (const auto& d : artifacts) {
    const fs::path p(d);
    in.artifacts.push_back(mm::read_artifact_test((p / "calibration.csv").string(), (p / "horizontal.csv").string(),
                                                  (p / "vertical.csv").string(), other));
  }
  for (const auto& f : runouts) in.runouts.push_back(mm::read_runout_check(f));
}

void add_latest_inputs(mm::MapInputs& in, const std::string& socket, std::ostream& notes) {
  DaemonClient c = connect_daemon(socket);
  const auto latest = [&](const std::string& kind, const std::string& axis) -> std::vector<std::string> {
    nlohmann::json req = {{"kind", kind}};
    if (!axis.empty()) req["axis"] = axis;
    const nlohmann::json r = c.request(results::request(results::RequestClass::params, req), results::MessageClass::params);
    if (results::has_class(r, results::MessageClass::error)) {
      notes << "map: " << kind << (axis.empty() ? "" : " " + axis) << ": " << r.value("message", "no session") << "\n";
      return {};
    }
    return results::read_header(r).derived;
  };
  for (const auto& f : latest(std::string(results::dbb_kind.name), ""))
    if (fs::path(f).extension() == ".csv") in.ballbar_runs.push_back(formats::read_dbb_run(f));
  for (const char* axis : {"x", "y", "z"})
    for (const auto& f : latest(std::string(results::straightness_kind.name), axis))
      if (f.ends_with(".angles.csv")) in.traverses.push_back(mm::read_traverse_test(f));
  for (const auto& f : latest(std::string(results::runout_kind.name), ""))
    if (f.ends_with(".runout.csv")) in.runouts.push_back(mm::read_runout_check(f));
}

void write_text_file(const std::string& path, const std::string& content) {
  try {
    write_file_atomically(path, content);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": cannot write (" + e.what() + ")");
  }
}

void print_volumetric(const nlohmann::json& v, const std::string& title) {
  const auto at = v["at_mm"];
  const auto tool = v["tool_offset_mm"];
  std::cout << title << ": " << pm(v["value_um"].get<double>(), v["u_um"].get<double>(), "um") << " (largest error over "
            << v["points"].get<std::size_t>() << " points, at X " << format_number(at[0].get<double>(), 4) << " Y "
            << format_number(at[1].get<double>(), 4) << " Z " << format_number(at[2].get<double>(), 4)
            << " mm; tool offset " << format_number(tool[0].get<double>(), 4) << " "
            << format_number(tool[1].get<double>(), 4) << " " << format_number(tool[2].get<double>(), 4) << " mm)\n"
            << "  E_VX " << format_number(v["E_VX_um"].get<double>(), 3) << " um, E_VY "
            << format_number(v["E_VY_um"].get<double>(), 3) << " um, E_VZ " << format_number(v["E_VZ_um"].get<double>(), 3)
            << " um (ranges of the components); RMS " << format_number(v["rms_um"].get<double>(), 3) << " um\n"
            << "  definition: " << v["definition"].get<std::string>() << "\n";
  if (!v["missing"].empty()) {
    std::string m;
    for (const auto& x : v["missing"]) m += (m.empty() ? "" : ", ") + x.get<std::string>();
    std::cout << "  NOT the machine's figure: it leaves out what the tests did not determine (" << m << ")\n";
  }
}

void print_map(const nlohmann::json& j) {
  const mm::ErrorMap m = mm::map_from_json(j, "map");
  std::cout << "error map of " << (m.machine.empty() ? "the machine" : m.machine) << "; travel";
  for (int a = 0; a < 3; ++a)
    std::cout << " " << "XYZ"[a] << " " << format_number(m.travel[static_cast<std::size_t>(a)].lo_m * 1e3, 5) << ".."
              << format_number(m.travel[static_cast<std::size_t>(a)].hi_m * 1e3, 5) << " mm";
  std::cout << "; tool offset " << format_number(m.tool_offset_m[0] * 1e3, 4) << " "
            << format_number(m.tool_offset_m[1] * 1e3, 4) << " " << format_number(m.tool_offset_m[2] * 1e3, 4) << " mm\n";
  std::vector<std::vector<std::string>> rows = {{"error", "what", "RMS", "peak to valley", "u (RMS)", "orders", "from"}};
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < mm::components; ++c) {
      const mm::ErrorFunction& f = m.function(a, c);
      const std::string what = mm::role_name(mm::role_of(a, c)) + " of " + std::string(1, "XYZ"[a]) +
                               (mm::role_of(a, c) == mm::Role::straightness ? " in " + mm::axis_name(c) : "");
      if (!f.determined) {
        rows.push_back({mm::function_name(a, c), what, "-", "-", "-", "-", "not determined (below)"});
        continue;
      }
      const auto fig = mm::function_figures(m, a, c);
      const std::string unit = c < 3 ? "um" : "urad";
      std::string orders;
      for (int o : f.orders) orders += (orders.empty() ? "P" : ",") + std::to_string(o);
      rows.push_back({mm::function_name(a, c), what, format_number(fig.rms * 1e6, 3) + " " + unit,
                      format_number(fig.peak_to_valley * 1e6, 3) + " " + unit, format_number(fig.u_rms * 1e6, 2) + " " + unit,
                      orders, f.determined_by});
    }
  for (const auto& q : j["squareness"]) {
    const std::string name = q["iso_name"].get<std::string>();
    const std::string what = "squareness " + q["plane"].get<std::string>();
    if (!q["determined"].get<bool>()) {
      rows.push_back({name, what, "-", "", "-", "", "not determined (below)"});
      continue;
    }
    rows.push_back({name, what, with_uncertainty(q["iso_value_urad"].get<double>(), q["u_urad"].get<double>()) + " urad",
                    "", "", "", q["determined_by"].get<std::string>()});
  }
  std::cout << aligned_rows(rows, {false, false, true, true, true, false, false});
  std::cout << "  (functions relative to the map's gauge: zero mean, a straightness about its least-squares line; "
               "squareness in ISO 230-1 signs; docs/map.md)\n";
  bool header = false;
  for (const auto& f : j["functions"])
    if (!f["determined"].get<bool>()) {
      if (!header) std::cout << "not determined by the day's tests:\n";
      header = true;
      std::cout << "  " << f["name"].get<std::string>() << ": " << f["why"].get<std::string>() << "\n";
    }
  for (const auto& q : j["squareness"])
    if (!q["determined"].get<bool>()) {
      if (!header) std::cout << "not determined by the day's tests:\n";
      header = true;
      std::cout << "  " << q["iso_name"].get<std::string>() << " (squareness " << q["plane"].get<std::string>()
                << "): " << q["why"].get<std::string>() << "\n";
    }
  if (j.contains("backlash") && !j["backlash"].empty()) {
    std::cout << "backlash (ballbar; for the per-joint tables):";
    for (const auto& b : j["backlash"])
      std::cout << " " << b["axis"].get<std::string>() << " " << pm(b["value_um"].get<double>(), b["u_um"].get<double>(), "um");
    std::cout << "\n";
  }
  if (j.contains("checks") && !j["checks"].empty()) {
    std::cout << "cross-checks where tests overlap (consistent: the difference within twice its u):\n";
    for (const auto& c : j["checks"]) {
      const std::string unit = c["unit"].get<std::string>();
      std::cout << "  " << c["name"].get<std::string>() << ": " << c["first"].get<std::string>() << " "
                << pm(c["value_first"].get<double>(), c["u_first"].get<double>(), unit) << ", "
                << c["second"].get<std::string>() << " "
                << pm(c["value_second"].get<double>(), c["u_second"].get<double>(), unit) << ": "
                << (c["consistent"].get<bool>() ? "consistent" : "NOT consistent") << " (difference "
                << pm(c["difference"].get<double>(), c["u_difference"].get<double>(), unit) << ")";
      if (!c["consistent"].get<bool>()) std::cout << "; " << c["note"].get<std::string>();
      std::cout << "\n";
    }
  }
  if (j.contains("volumetric")) print_volumetric(j["volumetric"], "volumetric accuracy");
  std::cout << "the tests' readings about the map (the noise each was weighted with):\n";
  std::vector<std::vector<std::string>> g = {{"test", "readings", "residual RMS", "noise"}};
  for (const auto& x : j["groups"])
    g.push_back({x["test"].get<std::string>(), std::to_string(x["observations"].get<std::size_t>()),
                 format_number(x["residual_rms"].get<double>(), 3) + " " + x["unit"].get<std::string>(),
                 format_number(x["sigma"].get<double>(), 3) + " " + x["unit"].get<std::string>()});
  std::cout << aligned_rows(g, {false, true, true, true});
  for (const auto& n : j.value("notes", nlohmann::json::array())) std::cout << "note: " << n.get<std::string>() << "\n";
}

void write_map_report(const nlohmann::json& map, const std::string& path) {
  report::ReportOptions o;
  o.title = "Guideway error map";
  write_text_file(path, report::render_map_report(map, o));
}

std::vector<std::string> export_map(const std::string& map_path, const std::string& out_dir, double step_m) {
  const nlohmann::json j = mm::read_map_json(map_path);
  const mm::ErrorMap m = mm::map_from_json(j, map_path);
  mm::ExportOptions o;
  o.step_m = step_m;
  std::vector<mm::ExportFile> files;
  try {
    files = mm::map_exports(m, mm::backlash_from_json(j, map_path), o, fs::path(map_path).filename().string());
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(std::string("map export: ") + e.what());
  }
  fs::create_directories(out_dir);
  // One set: a controller must never load new tables beside an earlier set's.
  std::vector<NamedContent> set;
  std::vector<std::string> written;
  for (const auto& f : files) {
    set.push_back({f.name, f.content});
    written.push_back((fs::path(out_dir) / f.name).string());
  }
  write_file_set_atomically(out_dir, set, mm::map_export_names());
  return written;
}

}  // namespace guideway::cli
