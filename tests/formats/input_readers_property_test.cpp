// Every reader of docs/formats.md against random files (issue 46 item 3): a valid file of each format, and
// thousands of broken ones made from it (numbers replaced by 1e308, nan, -0 or words, lines cut, dropped,
// doubled or swapped, bytes and commas inserted, the file truncated or random bytes). Each gives a result or
// a clear error: an exception of the readers' kinds whose message names the file, never another exception
// (bad_alloc, out_of_range, length_error). A result keeps every value inside the format's plausible bounds
// (docs/formats.md "Limits"). The CLI over the same files, special files and the size and row bounds:
// tests/formats/input_files_cli_test.py.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "core/csv_table.hpp"
#include "core/input_file.hpp"
#include "core/number_format.hpp"
#include "core/toml_access.hpp"
#include "formats/compensation_files.hpp"
#include "formats/dbb_run.hpp"
#include "formats/profile_files.hpp"
#include "formats/raw_recording.hpp"
#include "models/artifact/artifact.hpp"
#include "models/explain/runout_explain.hpp"
#include "models/explain/traverse_explain.hpp"
#include "models/flatness/runout.hpp"
#include "models/flatness/straightness.hpp"
#include "models/flatness/workpiece_flatness.hpp"
#include "test_support.hpp"

namespace guideway {
namespace {

// Valid files of the formats, small.
std::string dbb_run_text() {
  std::string t =
      "# format = guideway/dbb-run/1\n# radius_mm = 100\n# height_mm = 0\n# direction = ccw\n"
      "# feed_mm_per_min = 1000\n# plane = xy\n# center_a_mm = 0\n# center_b_mm = 0\nt_s,angle_deg,dL_um\n";
  for (int i = 0; i < 120; ++i)
    t += shortest(i * 0.05) + "," + shortest(i * 3.0) + "," + shortest(2 * std::sin(i * 0.1)) + "\n";
  return t;
}

std::string traverse_text() {
  std::string t = "# step_mm = 10\nx_mm,pitch_arcsec,yaw_arcsec,t_s,pass\n";
  for (int pass = 1; pass <= 2; ++pass)
    for (int i = 0; i < 12; ++i) {
      const int k = pass == 1 ? i : 11 - i;
      t += std::to_string(k * 10) + "," + shortest(0.1 * k - 0.3) + ",-0.4," + std::to_string(pass * 100 + i) + "," +
           std::to_string(pass) + "\n";
    }
  return t;
}

std::string runout_text() {
  std::string t =
      "# plate_diameter_mm = 1000\n# parallelism_um = 2.5\n# travel_mm = 600\n# rpm = 60\nangle_deg,runout_um\n";
  for (int i = 0; i < 72; ++i) t += std::to_string(i * 10) + "," + shortest(0.15 * std::cos(i * 10 * 0.01745)) + "\n";
  return t;
}

std::string profile_text() {
  std::string t = "# format = guideway/profile/1\n# feed_mm_per_min = 2\n# spindle_rpm = 100\nx_mm,z_um\n";
  for (int i = 0; i < 70; ++i) t += shortest(i * 0.05) + "," + shortest(0.2 * std::sin(i * 0.3)) + "\n";
  return t;
}

std::string artifact_text() {
  return "# format = guideway/artifact/1\n# placement = calibration\n# k_um_per_px = 1.6\n# m_px_per_arcsec = 0.44\n"
         "target,X_M_mm,Y_M_mm,x_M_px,y_M_px,x_F_px,y_F_px\n0,50,0,6.5,4.1,3.0,5.5\n1,100,0,-7.3,21.2,2.2,1.9\n"
         "2,150,0,1.0,2.0,3.0,4.0\n";
}

std::string k_scan_text() { return "# scan = displacement\nX_M_mm,x_M_px\n0,0\n0.01,6.2\n0.02,12.6\n0.03,18.7\n"; }

std::string straightness_csv_text() {
  return "# format = guideway/straightness/1\n# plane = xy\nmoving_axis,position_mm,corrected_axis,correction_mm\n"
         "x,-100,y,-0.007\nx,0,y,0\nx,100,y,0.007\ny,-100,x,0.001\ny,100,x,-0.001\n";
}

std::string comp_text() { return "-100.000000 -100.005262 -99.999265\n0 0 0\n100.000000 100.001456 100.007452\n"; }

std::string raw_text() {
  std::string t =
      "# format = guideway/raw/1\n# device = c\n# driver = counting\n# started_utc = 2026-11-21T06:31:02.114Z\n"
      "# started_mono_ns = 2201337459911\n# kind = mean\n# options = {}\n# session = s\nt_mono_ns,seq,flags,count_1\n";
  for (int i = 0; i < 20; ++i)
    t += std::to_string(2201338004120LL + i * 500000LL) + "," + std::to_string(1088 + i) + ",0," +
         std::to_string(1088 + i) + "\n";
  return t + "# end = complete\n# samples = 20\n";
}

std::string config_text() {
  return "[daemon]\nsocket = \"/tmp/x.sock\"\nstatus_period_s = 0.5\n[[device]]\nname = \"c\"\ndriver = \"counting\"\n";
}

// One broken variant of `valid`.
std::string mutate(const std::string& valid, std::mt19937& rng) {
  std::vector<std::string> lines;
  for (std::size_t a = 0; a < valid.size();) {
    const std::size_t b = valid.find('\n', a);
    lines.push_back(valid.substr(a, b == std::string::npos ? std::string::npos : b - a));
    a = b == std::string::npos ? valid.size() : b + 1;
  }
  const auto pick = [&](std::size_t n) { return static_cast<std::size_t>(rng() % std::max<std::size_t>(n, 1)); };
  static const std::vector<std::string> numbers = {
      "1e308", "-1e308", "nan", "inf", "-inf", "1e-320", "-0", "0",  "99999999999999999999999",
      "1e300", "-1e6",   "",    "x",   "0x10", "1,5",    "+",  " 7 "};
  const int kind = static_cast<int>(rng() % 10);
  std::string out;
  switch (kind) {
    case 0: {  // a number replaced
      std::string& l = lines[pick(lines.size())];
      std::size_t at = l.find_first_of("0123456789");
      if (at != std::string::npos) {
        std::size_t end = l.find_first_not_of("0123456789.e-+", at);
        l.replace(at, (end == std::string::npos ? l.size() : end) - at, numbers[pick(numbers.size())]);
      }
      break;
    }
    case 1:
      lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(pick(lines.size())));
      break;
    case 2: {
      const std::size_t i = pick(lines.size());
      lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(i), lines[i]);
      break;
    }
    case 3:
      std::swap(lines[pick(lines.size())], lines[pick(lines.size())]);
      break;
    case 4: {  // bytes inserted
      std::string& l = lines[pick(lines.size())];
      for (int k = 0; k < 1 + static_cast<int>(rng() % 4); ++k)
        l.insert(l.begin() + static_cast<std::ptrdiff_t>(pick(l.size() + 1)), static_cast<char>(rng() % 256));
      break;
    }
    case 5:  // many commas
      lines[pick(lines.size())].append(std::string(1 + rng() % 5000, ','));
      break;
    case 6:  // a metadata line's value
      for (auto& l : lines)
        if (l.starts_with("#") && l.find('=') != std::string::npos && rng() % 3 == 0)
          l = l.substr(0, l.find('=') + 1) + " " + numbers[pick(numbers.size())];
      break;
    case 7: {  // every number of one column scaled by 1e300
      const std::size_t col = pick(4);
      for (auto& l : lines) {
        if (l.empty() || l[0] == '#' || !std::isdigit(static_cast<unsigned char>(l[0]))) continue;
        std::size_t a = 0;
        for (std::size_t c = 0; c < col && a != std::string::npos; ++c)
          a = l.find(',', a) == std::string::npos ? std::string::npos : l.find(',', a) + 1;
        if (a != std::string::npos && a < l.size()) l.insert(a, "1e300*");
      }
      break;
    }
    case 8:  // random bytes
      out.resize(rng() % 400);
      for (char& c : out) c = static_cast<char>(rng() % 256);
      return out;
    default:
      break;  // truncated below
  }
  for (const auto& l : lines) out += l + "\n";
  if (kind == 9) out.resize(pick(out.size()));
  return out;
}

// The readers' kinds of error; anything else (std::out_of_range, std::length_error, std::bad_alloc) is a defect.
bool clear_error(const std::exception& e) {
  return dynamic_cast<const std::runtime_error*>(&e) != nullptr ||
         dynamic_cast<const std::invalid_argument*>(&e) != nullptr;
}

struct Reader {
  std::string name;
  std::string source;  // the file name errors must name
  std::string valid;
  std::function<void(const std::string&)> read;  // throws on a bad file; checks a result's bounds
};

std::vector<Reader> readers(const test::TempDir& dir) {
  namespace fl = models::flatness;
  const auto within = [](double v, double bound, const std::string& what) {
    if (!(std::abs(v) <= bound)) ADD_FAILURE() << what << " = " << v << " accepted, outside +-" << bound;
  };
  return {
      {"csv table", "t.csv", traverse_text(),
       [](const std::string& t) { (void)parse_csv_table(t, "t.csv").numbers(0); }},
      {"dbb run", "run.csv", dbb_run_text(),
       [&](const std::string& t) {
         const formats::DbbRun r = formats::parse_dbb_run(t, "run.csv");
         within(r.radius_m, 2.0, "radius_m");
         EXPECT_GT(r.t_s.back(), r.t_s.front());
         for (std::size_t i = 0; i < r.t_s.size(); ++i) {
           within(r.angle_rad[i], 3600 * 0.0175, "angle_rad");
           within(r.dL_m[i], 1e-3, "dL_m");
         }
       }},
      {"traverse", "t.csv", traverse_text(),
       [&](const std::string& t) {
         const fl::AngleTraverse tr = fl::parse_angle_traverse(t, "t.csv");
         for (double x : tr.x_m) within(x, 200.0, "x_m");
         within(tr.step_m, 10.0, "step_m");
       }},
      {"traverse passes", "t.csv", traverse_text(),
       [&](const std::string& t) {
         for (const auto& p : models::explain::parse_traverse_passes(t, "t.csv", 0, {}))
           for (double s : p.t_s) within(s, 1e7, "t_s");
       }},
      {"run-out", "r.csv", runout_text(),
       [&](const std::string& t) {
         const fl::RunoutRevolution r = fl::parse_runout_revolution(t, "r.csv");
         for (double v : r.runout_m) within(v, 0.01, "runout_m");
         within(r.plate_diameter_m, 100.0, "plate_diameter_m");
       }},
      {"run-out record", "r.csv", runout_text(),
       [](const std::string& t) { (void)models::explain::parse_runout_record(t, "r.csv"); }},
      {"profile", "p.csv", profile_text(),
       [&](const std::string& t) {
         const formats::Profile p = formats::parse_profile_csv(t, "p.csv");
         for (double z : p.z_m)
           if (!std::isnan(z)) within(z, 0.01, "z_m");
       }},
      {"workpiece profile", "p.csv", profile_text(),
       [](const std::string& t) { (void)fl::parse_workpiece_profile(t, "p.csv"); }},
      {"artifact", "a.csv", artifact_text(),
       [](const std::string& t) {
         (void)models::artifact::parse_artifact_readings(t, "a.csv", models::artifact::ArtifactPlacement::calibration);
       }},
      {"k scan", "k.csv", k_scan_text(), [](const std::string& t) { (void)models::artifact::fit_k_scan(t, "k.csv"); }},
      {"straightness.csv", "straightness.csv", straightness_csv_text(),
       [](const std::string& t) { (void)formats::parse_straightness_csv(t, "straightness.csv"); }},
      {"x.comp", "x.comp", comp_text(), [](const std::string& t) { (void)formats::parse_linuxcnc_comp(t, "x.comp"); }},
      {"raw recording", dir.file("raw.csv"), raw_text(),
       [&](const std::string& t) {
         std::ofstream(dir.file("raw.csv"), std::ios::binary | std::ios::trunc) << t;
         (void)formats::read_raw_recording(dir.file("raw.csv"));
       }},
      {"configuration", "g.toml", config_text(), [](const std::string& t) { (void)parse_toml(t, "g.toml"); }},
  };
}

TEST(InputReaders, EachValidFileReads) {
  test::TempDir dir;
  for (const Reader& r : readers(dir)) EXPECT_NO_THROW(r.read(r.valid)) << r.name;
}

TEST(InputReaders, BrokenFilesGiveAResultOrAClearErrorNamingTheFile) {
  test::TempDir dir;
  std::mt19937 rng(46);
  for (const Reader& r : readers(dir)) {
    int errors = 0;
    for (int n = 0; n < 250; ++n) {
      const std::string text = mutate(r.valid, rng);
      try {
        r.read(text);
      } catch (const std::exception& e) {
        ++errors;
        ASSERT_TRUE(clear_error(e)) << r.name << " case " << n << ": " << typeid(e).name() << ": " << e.what();
        EXPECT_NE(std::string(e.what()).find(r.source), std::string::npos)
            << r.name << " case " << n << ": the error does not name the file: " << e.what();
      }
    }
    EXPECT_GT(errors, 25) << r.name << ": the mutations should break most files";
  }
}

TEST(InputReaders, AnX3pContainerBrokenAnywhereIsAClearError) {
  formats::X3pSurface s;
  s.feature_type = "SUR";
  s.size_x = 8;
  s.size_y = 3;
  s.size_z = 1;
  s.increment_x_m = 1e-6;
  s.increment_y_m = 1e-6;
  s.z_m.assign(24, 1e-7);
  std::mt19937 rng(5436);
  for (const bool deflate : {false, true}) {
    const std::string valid = formats::build_x3p(s, deflate);
    EXPECT_NO_THROW((void)formats::parse_x3p(valid, "s.x3p"));
    for (int n = 0; n < 400; ++n) {
      std::string bytes = valid;
      for (int k = 0; k < 1 + static_cast<int>(rng() % 3); ++k) bytes[rng() % bytes.size()] = static_cast<char>(rng());
      if (n % 5 == 0) bytes.resize(rng() % bytes.size());
      try {
        (void)formats::parse_x3p(bytes, "s.x3p");
      } catch (const std::exception& e) {
        ASSERT_TRUE(clear_error(e)) << n << ": " << e.what();
        EXPECT_NE(std::string(e.what()).find("s.x3p"), std::string::npos) << e.what();
      }
    }
  }
}

// The row bound stops a reader where it is passed, and says where and how to raise it.
TEST(InputReaders, TheRowBoundStopsTheReaderThere) {
  const InputLimits before = input_limits();
  set_input_limits({before.max_bytes, 50});
  std::string error;
  try {
    (void)formats::parse_dbb_run(dbb_run_text(), "run.csv");
  } catch (const formats::DbbRunFormatError& e) {
    error = e.what();
  }
  std::string csv_error;
  try {
    (void)parse_csv_table(runout_text(), "r.csv");
  } catch (const CsvError& e) {
    csv_error = e.what();
  }
  set_input_limits(before);
  EXPECT_EQ(error, "run.csv:60: more than 50 data rows, the limit a table (guideway --max-input-rows)");
  EXPECT_EQ(csv_error, "r.csv:56: more than 50 data rows, the limit a table (guideway --max-input-rows)");
}

}  // namespace
}  // namespace guideway

namespace guideway {
namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(accepted)";
}

// Issue 46 item 4, each input the probe found accepted with exit 0: refused at its line, with the bound.
TEST(InputReaders, TheProbesNonPhysicalInputsAreRefusedAtTheirLineWithTheBound) {
  std::string runout = runout_text();
  runout.replace(runout.find("\n0,") + 3, runout.find('\n', runout.find("\n0,") + 1) - runout.find("\n0,") - 3,
                 "1e308");
  EXPECT_EQ(error_of([&] { (void)models::flatness::parse_runout_revolution(runout, "r.csv"); }),
            "r.csv:6: runout_um = 1e+308 is outside [-10000, 10000] um, a micrometer's range (10 mm)");

  std::string angles;  // every angle x 1e300
  const std::string run = dbb_run_text();
  for (std::size_t a = 0; a < run.size();) {
    const std::size_t b = run.find('\n', a);
    std::string l = run.substr(a, b - a);
    if (!l.empty() && std::isdigit(static_cast<unsigned char>(l[0]))) {
      const std::size_t c1 = l.find(','), c2 = l.find(',', c1 + 1);
      l = l.substr(0, c1 + 1) + l.substr(c1 + 1, c2 - c1 - 1) + "e300" + l.substr(c2);
    }
    angles += l + "\n";
    a = b + 1;
  }
  EXPECT_EQ(
      error_of([&] { (void)formats::parse_dbb_run(angles, "run.csv"); }),
      "run.csv:11: angle_deg = 3e300 is outside [-3600, 3600] deg, a circle's angle, unwrapped or not (10 turns)");

  std::string radius = run;
  radius.replace(radius.find("radius_mm = 100"), 15, "radius_mm = 1e308");
  EXPECT_EQ(
      error_of([&] { (void)formats::parse_dbb_run(radius, "run.csv"); }),
      "run.csv:2: radius_mm = 1e308 is outside (0, 2000] mm, a ballbar's radius (bars with extensions reach 1.5 m)");

  std::string still;  // every time 0
  for (std::size_t a = 0; a < run.size();) {
    const std::size_t b = run.find('\n', a);
    std::string l = run.substr(a, b - a);
    if (!l.empty() && std::isdigit(static_cast<unsigned char>(l[0]))) l = "0" + l.substr(l.find(','));
    still += l + "\n";
    a = b + 1;
  }
  EXPECT_EQ(error_of([&] { (void)formats::parse_dbb_run(still, "run.csv"); }),
            "run.csv: t_s does not advance: every sample is at t = 0 s");

  std::string pass = traverse_text();
  pass.replace(pass.find(",1\n"), 3, ",-1\n");
  EXPECT_EQ(error_of([&] { (void)models::explain::parse_traverse_passes(pass, "t.csv", 0, {}); }),
            "t.csv:3: pass = -1 is not a pass number (a whole number in [1, 1000000])");
  pass = traverse_text();
  pass.replace(pass.find(",1\n"), 3, ",1.5\n");
  EXPECT_EQ(error_of([&] { (void)models::flatness::parse_angle_traverse(pass, "t.csv"); }),
            "t.csv:3: pass = 1.5 is not a pass number (a whole number in [1, 1000000])");
}

}  // namespace
}  // namespace guideway
