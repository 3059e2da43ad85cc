#pragma once
// A day's tests as one file (`day.json`, format guideway/map-day/1; docs/map.md "Files"): the machine, the
// tool offset the tests were made with, the volume they cover, and each test with its files (paths relative
// to the manifest): "dbb" (a plane's run files), "straightness" (an axis' traverse file), "artifact" (an
// axis' calibration, horizontal and vertical files, where it lay: other_mm) and "runout" (a run-out
// revolution). `guideway simulate day` writes one; `guideway map fit --day` reads it. Throws
// std::invalid_argument naming the manifest (and the test) for what it cannot use; CsvError and
// DbbRunFormatError from the files themselves.

#include <string>
#include <vector>

#include "models/map/map_inputs.hpp"

namespace guideway::models::map {

inline constexpr const char* day_format_id = "guideway/map-day/1";

// One test of a manifest as listed (paths resolved against the manifest's directory).
struct DayEntry {
  std::string kind;   // dbb | straightness | artifact | runout
  std::string where;  // plane or axis
  std::vector<std::string> files;
  Vec3 other_m{};  // artifact
};

struct Day {
  std::string path;
  std::string machine;
  Vec3 tool_offset_m{};
  std::optional<std::array<Travel, 3>> travel;
  std::vector<DayEntry> tests;
};

Day read_day(const std::string& path);

// Every test of the day read and identified as far as the map needs (artifacts by models/artifact, the run-out
// by Mu's Eq. 21), into the map's inputs.
MapInputs day_inputs(const Day& day);

// The single tests, as `guideway map fit` takes them without a manifest.
ArtifactTest read_artifact_test(const std::string& calibration, const std::string& horizontal,
                                const std::string& vertical, const Vec3& other_m);
RunoutCheck read_runout_check(const std::string& path);

}  // namespace guideway::models::map
