// A day's tests as one file (day.hpp, guideway/map-day/1): the machine, the tool offset, the volume, each test's files.
#include "models/map/day.hpp"

#include <filesystem>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "core/csv_table.hpp"
#include "models/flatness/runout.hpp"
#include "models/map/json_fields.hpp"

namespace guideway::models::map {

namespace fs = std::filesystem;

Day read_day(const std::string& path) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_text_file(path));
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(path + ": not a day manifest (JSON: " + std::string(e.what()) + ")");
  }
  if (!j.is_object() || j.value("format", nlohmann::json()) != day_format_id)
    throw std::invalid_argument(path + ": not a day manifest (format must be " + day_format_id + ")");
  Day d;
  d.path = path;
  const fs::path dir = fs::path(path).parent_path();
  d.machine = fields::text(j, "machine", path);
  if (j.contains("tool_offset_mm")) d.tool_offset_m = fields::vec_mm(j["tool_offset_mm"], path + ": tool_offset_mm");
  if (j.contains("travel_mm")) d.travel = fields::travel_mm(j["travel_mm"], path);
  if (!j.contains("tests") || !j["tests"].is_array())
    throw std::invalid_argument(path + ": no \"tests\" list");
  std::size_t k = 0;
  for (const auto& t : j["tests"]) {
    ++k;
    const std::string where = path + ": test " + std::to_string(k);
    DayEntry e;
    e.kind = fields::text(t, "kind", where);
    if (e.kind != "dbb" && e.kind != "straightness" && e.kind != "artifact" && e.kind != "runout")
      throw std::invalid_argument(where + ": kind '" + e.kind + "' (dbb, straightness, artifact or runout)");
    e.where = fields::text(t, e.kind == "dbb" ? "plane" : "axis", where);
    if (e.kind == "dbb" && squareness_index(e.where) < 0)
      throw std::invalid_argument(where + ": plane '" + e.where + "' (xy, xz or yz)");
    if ((e.kind == "straightness" || e.kind == "artifact") && !parse_axis(e.where))
      throw std::invalid_argument(where + ": axis '" + e.where + "' (x, y or z)");
    if (!t.contains("files") || !t["files"].is_array() || t["files"].empty())
      throw std::invalid_argument(where + ": no files");
    for (const auto& f : t["files"]) {
      if (!f.is_string() || f.get<std::string>().empty())
        throw std::invalid_argument(where + ": file names must be non-empty strings");
      const fs::path p(f.get<std::string>());
      e.files.push_back((p.is_absolute() ? p : dir / p).string());
    }
    if (e.kind == "artifact") {
      if (e.files.size() != 3)
        throw std::invalid_argument(where + ": an artifact is three files (calibration, horizontal, vertical)");
      if (t.contains("other_mm")) e.other_m = fields::vec_mm(t["other_mm"], where + ": other_mm");
    }
    if (e.kind == "straightness" && e.files.size() != 1)
      throw std::invalid_argument(where + ": a traverse is one file");
    d.tests.push_back(std::move(e));
  }
  return d;
}

ArtifactTest read_artifact_test(const std::string& calibration, const std::string& horizontal,
                                const std::string& vertical, const Vec3& other_m) {
  using artifact::ArtifactPlacement;
  const auto c = artifact::read_artifact_readings(calibration, ArtifactPlacement::calibration);
  const auto h = artifact::read_artifact_readings(horizontal, ArtifactPlacement::horizontal);
  const auto v = artifact::read_artifact_readings(vertical, ArtifactPlacement::vertical);
  return artifact_test(artifact::identify_artifact(c, h, v), other_m,
                       "artifact " + axis_name(c.axis) + " (" + fs::path(calibration).parent_path().string() + ")");
}

RunoutCheck read_runout_check(const std::string& path) {
  const auto r = flatness::identify_runout(flatness::read_runout_revolution(path));
  return {path, r.deflection_rad, r.u_deflection_rad};
}

MapInputs day_inputs(const Day& day) {
  MapInputs in;
  in.machine = day.machine;
  in.tool_offset_m = day.tool_offset_m;
  in.travel = day.travel;
  for (const auto& t : day.tests) {
    if (t.kind == "dbb") {
      for (const auto& f : t.files) {
        auto run = formats::read_dbb_run(f);
        if (run.plane != t.where)
          throw std::invalid_argument(day.path + ": " + f + " is a run in " + run.plane + ", listed for " + t.where);
        in.ballbar_runs.push_back(std::move(run));
      }
    } else if (t.kind == "straightness") {
      in.traverses.push_back(read_traverse_test(t.files[0], parse_axis(t.where)));
    } else if (t.kind == "artifact") {
      ArtifactTest a = read_artifact_test(t.files[0], t.files[1], t.files[2], t.other_m);
      if (a.axis != *parse_axis(t.where))
        throw std::invalid_argument(day.path + ": " + t.files[0] + " is an artifact along " + axis_name(a.axis) +
                                    ", listed for " + t.where);
      in.artifacts.push_back(std::move(a));
    } else {
      for (const auto& f : t.files) in.runouts.push_back(read_runout_check(f));
    }
  }
  return in;
}

}  // namespace guideway::models::map
