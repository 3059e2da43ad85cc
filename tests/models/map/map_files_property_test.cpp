// The error map's files as a user or another tool could hand them over, broken: the map file (guideway/map/1),
// the day's manifest (guideway/map-day/1) and the ISO 230-1 tables. Each is mutated at random (a member
// removed, a value of another type, a line dropped, doubled or a byte changed) and read back: either it reads,
// and what it gives keeps the format's promises, or it is refused with the reader's own error naming the file
// (std::invalid_argument, formats::Iso230TableError), never a JSON library's exception or a crash.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "formats/iso230_tables.hpp"
#include "map_test_support.hpp"
#include "models/map/day.hpp"
#include "models/map/exports.hpp"
#include "models/map/map_json.hpp"
#include "test_support.hpp"

using namespace guideway;
using namespace guideway::map_test;

namespace {

const std::string kWork = "map_files_property_work";

// The JSON pointers below the document's root; of a long list (the covariance) its first two and its last
// elements, so that every kind of member is hit about as often.
void pointers(const nlohmann::json& j, const nlohmann::json::json_pointer& at,
              std::vector<nlohmann::json::json_pointer>& out) {
  if (j.is_object()) {
    for (const auto& [key, value] : j.items()) {
      out.push_back(at / key);
      pointers(value, at / key, out);
    }
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) {
      if (j.size() > 8 && i > 1 && i + 1 < j.size()) continue;
      out.push_back(at / i);
      pointers(j[i], at / i, out);
    }
  }
}

// One member or element removed or replaced by a value of another kind; says what it did.
std::string mutate(nlohmann::json& j, std::mt19937& rng) {
  std::vector<nlohmann::json::json_pointer> all;
  pointers(j, nlohmann::json::json_pointer(), all);
  const auto& p = all[std::uniform_int_distribution<std::size_t>(0, all.size() - 1)(rng)];
  const std::vector<nlohmann::json> others{nullptr,   "text", -1.0,  0,    1e300, true, nlohmann::json::array(),
                                           {1, 2, 3}, {"x"},  {1, 2}, nlohmann::json::object(), {{"a", 1}}};
  const auto pick = std::uniform_int_distribution<std::size_t>(0, others.size())(rng);
  if (pick == others.size()) {
    const auto parent = p.parent_pointer();
    if (j.at(parent).is_object()) {
      j.at(parent).erase(p.back());
    } else {
      j.at(parent).erase(static_cast<std::size_t>(std::stoul(p.back())));
    }
    return "removed " + p.to_string();
  }
  j.at(p) = others[pick];
  return p.to_string() + " = " + others[pick].dump();
}

// A byte of the text changed to one a hand edit or a transfer could leave.
std::string mutate_text(std::string text, std::mt19937& rng) {
  const std::string bytes = "0123456789.-+eE,;\n #\"[]{}:nax\t";
  const auto at = std::uniform_int_distribution<std::size_t>(0, text.size() - 1)(rng);
  switch (std::uniform_int_distribution<int>(0, 2)(rng)) {
    case 0: text[at] = bytes[std::uniform_int_distribution<std::size_t>(0, bytes.size() - 1)(rng)]; break;
    case 1: text.erase(at, 1); break;
    default: text.insert(at, 1, bytes[std::uniform_int_distribution<std::size_t>(0, bytes.size() - 1)(rng)]);
  }
  return text;
}

void write(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

nlohmann::json example_map() {
  const simulators::emulators::DayPlan plan;
  mm::ErrorMap m = sm::truth_map(sm::load_machine_config(write_second_machine(kWork)), travel_of(plan), 3);
  m.covariance.assign(m.parameters * m.parameters, 0.0);
  for (std::size_t i = 0; i < m.parameters; ++i) m.covariance[i * m.parameters + i] = 1e-14;
  return mm::to_json(m);
}

// What a map that was read must be: its travel ascending, its values finite where it is determined.
void expect_usable(const mm::ErrorMap& m, const std::string& what) {
  for (int a = 0; a < 3; ++a) {
    const auto& t = m.travel[static_cast<std::size_t>(a)];
    ASSERT_LT(t.lo_m, t.hi_m) << what;
    for (int c = 0; c < mm::components; ++c) EXPECT_TRUE(std::isfinite(m.value(a, c, t.lo_m))) << what;
  }
  EXPECT_TRUE(m.covariance.empty() || m.covariance.size() == m.parameters * m.parameters) << what;
}

}  // namespace

TEST(MapFileProperty, ABrokenMapFileIsReadOrRefusedNamingTheFile) {
  const nlohmann::json good = example_map();
  expect_usable(mm::map_from_json(good, "good.json"), "the unbroken map");
  std::mt19937 rng(44);
  int refused = 0;
  const int rounds = 400;
  for (int i = 0; i < rounds; ++i) {
    nlohmann::json j = good;
    std::string what = mutate(j, rng);
    if (i % 3 == 0) what += ", " + mutate(j, rng);
    try {
      expect_usable(mm::map_from_json(j, "m.json"), what);
    } catch (const std::invalid_argument& e) {
      ++refused;
      EXPECT_EQ(std::string(e.what()).rfind("m.json: ", 0), 0u) << what << ": " << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": not the reader's error: " << e.what();
    }
  }
  // Most mutations hit something the map needs; some (a note, a name) do not.
  EXPECT_GT(refused, rounds / 4);
}

TEST(MapFileProperty, ABrokenMapFilesTextIsReadOrRefusedNamingTheFile) {
  const std::string good = example_map().dump(1);
  const test::TempDir dir;
  const std::string path = dir.file("map.json");
  std::mt19937 rng(230);
  for (int i = 0; i < 150; ++i) {
    write(path, mutate_text(good, rng));
    try {
      expect_usable(mm::read_map(path), "round " + std::to_string(i));
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "round " << i << ": not the reader's error: " << e.what();
    }
  }
}

TEST(MapFileProperty, ABrokenDayManifestIsReadOrRefusedNamingTheFile) {
  const nlohmann::json good = {
      {"format", mm::day_format_id},
      {"machine", "m"},
      {"tool_offset_mm", {0, 0, -100}},
      {"travel_mm", {{"x", {-200, 200}}, {"y", {-200, 200}}, {"z", {-150, 150}}}},
      {"tests",
       {{{"kind", "dbb"}, {"plane", "xy"}, {"files", {"dbb_xy_ccw.csv", "dbb_xy_cw.csv"}}},
        {{"kind", "straightness"}, {"axis", "y"}, {"files", {"traverse_y.csv"}}},
        {{"kind", "artifact"},
         {"axis", "z"},
         {"other_mm", {10, 20, 0}},
         {"files", {"a/calibration.csv", "a/horizontal.csv", "a/vertical.csv"}}},
        {{"kind", "runout"}, {"files", {"runout.csv"}}}}}};
  const test::TempDir dir;
  const std::string path = dir.file("day.json");
  write(path, good.dump());
  ASSERT_EQ(mm::read_day(path).tests.size(), 4u);
  std::mt19937 rng(16907);
  for (int i = 0; i < 300; ++i) {
    nlohmann::json j = good;
    std::string what = mutate(j, rng);
    write(path, i % 4 == 3 ? mutate_text(good.dump(), rng) : j.dump());
    if (i % 4 == 3) what = "a byte of the text";
    try {
      const mm::Day d = mm::read_day(path);
      for (const auto& t : d.tests) EXPECT_FALSE(t.files.empty()) << what;
      if (d.travel) {
        for (const auto& t : *d.travel) EXPECT_LT(t.lo_m, t.hi_m) << what;
      }
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << what << ": " << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": not the reader's error: " << e.what();
    }
  }
}

// The tables a controller loads: a line dropped or doubled, a byte changed. What reads keeps the writer's
// promises (positions strictly ascending, six finite values at each).
TEST(Iso230TableProperty, ABrokenTableIsReadOrRefusedWithItsError) {
  const simulators::emulators::DayPlan plan;
  const mm::ErrorMap m = sm::truth_map(sm::load_machine_config(write_second_machine(kWork)), travel_of(plan), 3);
  std::string axis_table, squareness;
  for (const auto& f : mm::map_exports(m, {}, {}, "truth")) {
    if (f.name == "iso230_y.csv") axis_table = f.content;
    if (f.name == "iso230_squareness.csv") squareness = f.content;
  }
  ASSERT_FALSE(axis_table.empty());
  ASSERT_FALSE(squareness.empty());
  std::mt19937 rng(2301);
  const auto lines_of = [](const std::string& text) {
    std::vector<std::string> out;
    std::size_t from = 0;
    for (std::size_t nl; (nl = text.find('\n', from)) != std::string::npos; from = nl + 1)
      out.push_back(text.substr(from, nl - from + 1));
    return out;
  };
  int refused = 0;
  for (int i = 0; i < 600; ++i) {
    const bool table = i % 4 != 3;
    std::string text = table ? axis_table : squareness;
    if (i % 2 == 0) {
      text = mutate_text(text, rng);
    } else {
      auto lines = lines_of(text);
      const auto k = std::uniform_int_distribution<std::size_t>(0, lines.size() - 1)(rng);
      if (i % 3 == 0) {
        lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(k), lines[k]);
      } else {
        lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(k));
      }
      text.clear();
      for (const auto& l : lines) text += l;
    }
    try {
      if (table) {
        const auto t = formats::parse_iso230_axis_table(text, "t.csv");
        for (std::size_t r = 1; r < t.position_mm.size(); ++r) EXPECT_LT(t.position_mm[r - 1], t.position_mm[r]);
        for (const auto& column : t.values) {
          ASSERT_EQ(column.size(), t.position_mm.size());
          for (double v : column) EXPECT_TRUE(std::isfinite(v));
        }
      } else {
        const auto q = formats::parse_iso230_squareness(text, "q.csv");
        EXPECT_TRUE(std::isfinite(q.ec0y_urad) && std::isfinite(q.eb0z_urad) && std::isfinite(q.ea0z_urad));
      }
    } catch (const formats::Iso230TableError& e) {
      ++refused;
      EXPECT_NE(std::string(e.what()).find(table ? "t.csv" : "q.csv"), std::string::npos) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "round " << i << ": not the table's error: " << e.what();
    }
  }
  EXPECT_GT(refused, 0);
}
