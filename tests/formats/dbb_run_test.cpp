// DBB run files: round trip, and clear errors for degenerate input (too few points, partial arc,
// mismatched metadata, NaN, wrong format, mixed planes).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

#include "formats/dbb_run.hpp"
#include "models/dbb/identify.hpp"
#include "models/dbb/json.hpp"
#include "test_support.hpp"

namespace {

using namespace guideway::models::dbb;
using DbbRun = guideway::formats::DbbRun;

std::string header(const std::string& extra = "", const std::string& direction = "ccw") {
  return "# format = guideway/dbb-run/1\n# radius_mm = 100\n# height_mm = 0\n# direction = " + direction +
         "\n# feed_mm_per_min = 1000\n# plane = xy\n" + extra + "t_s,angle_deg,dL_um\n";
}

// n samples over `span_deg`, dL = 2 cos(zeta) um.
std::string rows(std::size_t n, double span_deg = 360.0, int dir = 1) {
  std::ostringstream o;
  for (std::size_t i = 0; i < n; ++i) {
    const double a = dir * span_deg * static_cast<double>(i) / static_cast<double>(n - 1);
    o << 0.01 * static_cast<double>(i) << "," << a << "," << 2 * std::cos(a * std::numbers::pi / 180) << "\n";
  }
  return o.str();
}

std::string error_of(const std::string& text) {
  try {
    (void)guideway::formats::parse_dbb_run(text, "run.csv");
  } catch (const guideway::formats::DbbRunFormatError& e) {
    return e.what();
  }
  return "";
}

TEST(DbbRunTest, ParsesAndRoundTrips) {
  const DbbRun r = guideway::formats::parse_dbb_run(header("# machine = vmc-1\n") + rows(361), "run.csv");
  EXPECT_EQ(r.angle_rad.size(), 361u);
  EXPECT_DOUBLE_EQ(r.radius_m, 0.1);
  EXPECT_EQ(r.direction, guideway::formats::DbbDirection::ccw);
  EXPECT_NEAR(r.feed_m_per_s, 1.0 / 60.0, 1e-15);
  EXPECT_NEAR(r.dL_m[0], 2e-6, 1e-15);
  EXPECT_EQ(r.metadata.at("machine"), "vmc-1");
  guideway::test::TempDir dir;
  guideway::formats::write_dbb_run(r, dir.file("a.csv"));
  const DbbRun back = guideway::formats::read_dbb_run(dir.file("a.csv"));
  ASSERT_EQ(back.angle_rad.size(), r.angle_rad.size());
  for (std::size_t i = 0; i < r.angle_rad.size(); ++i) {
    EXPECT_NEAR(back.angle_rad[i], r.angle_rad[i], 1e-9);
    EXPECT_NEAR(back.dL_m[i], r.dL_m[i], 1e-12);
  }
  EXPECT_EQ(back.metadata.at("machine"), "vmc-1");
}

// The session's raw recording given where its runs are expected (identify, explain, compensate): refused
// with the run files beside it named, or, without them, how to identify it again.
TEST(DbbRunTest, ARawRecordingIsRefusedNamingTheRunFilesBesideIt) {
  guideway::test::TempDir dir;
  const auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir.file(name)) << text;
    return dir.file(name);
  };
  const std::string recording = write("dbb-1.csv", "# format = guideway/raw/1\nt_ns,seq,flags,bar_length\n");
  const auto refusal = [&] {
    try {
      guideway::formats::read_dbb_run(recording);
    } catch (const guideway::formats::DbbRunFormatError& e) {
      return std::string(e.what());
    }
    return std::string("not refused");
  };
  EXPECT_NE(refusal().find("a raw recording (guideway/raw/1"), std::string::npos) << refusal();
  EXPECT_NE(refusal().find("guideway replay " + recording), std::string::npos) << refusal();
  const std::string run1 = write("dbb-1.run1.csv", header() + rows(361));
  const std::string run2 = write("dbb-1.run2.csv", header() + rows(361));
  write("dbb-1.params.json", "{}");
  write("dbb-10.run1.csv", header() + rows(361));  // another session's
  EXPECT_NE(refusal().find("give the files the session derived from it: " + run1 + " " + run2), std::string::npos)
      << refusal();
  EXPECT_EQ(refusal().find("dbb-10"), std::string::npos) << refusal();
  EXPECT_EQ(refusal().find("params.json"), std::string::npos) << refusal();
}

TEST(DbbRunTest, AcceptsWrappedAnglesExtraColumnsAndTrailer) {
  std::ostringstream o;
  o << header().substr(0, header().size() - std::string("t_s,angle_deg,dL_um\n").size())
    << "t_s,angle_deg,dL_um,x_mm\n";
  for (int i = 0; i <= 360; ++i) o << i * 0.01 << "," << (i + 180) % 360 << ",0.5,1\n";
  o << "# end = complete\n";
  const DbbRun r = guideway::formats::parse_dbb_run(o.str(), "w.csv");
  EXPECT_NEAR(r.angle_rad.back() - r.angle_rad.front(), 2 * std::numbers::pi, 1e-12);
}


// A controller's commanded position written beside the bar's reading (a live session with a linuxcnc-hal
// device): columns after dL_um, one value a sample; the reader takes the run as before. A column of the wrong
// length is the writer's error, named.
TEST(DbbRunTest, WritesExtraColumnsAfterTheReadings) {
  DbbRun r = guideway::formats::parse_dbb_run(header() + rows(361), "run.csv");
  std::vector<double> x_mm, y_mm;
  for (const double a : r.angle_rad) {
    x_mm.push_back(100 * std::cos(a));
    y_mm.push_back(100 * std::sin(a));
  }
  r.extra_columns = {{"x_cmd_mm", x_mm}, {"y_cmd_mm", y_mm}};
  const std::string text = guideway::formats::format_dbb_run(r);
  EXPECT_NE(text.find("\nt_s,angle_deg,dL_um,x_cmd_mm,y_cmd_mm\n"), std::string::npos) << text.substr(0, 400);
  EXPECT_NE(text.find(",100,0\n"), std::string::npos) << "the first sample's command (100, 0) mm";
  const DbbRun back = guideway::formats::parse_dbb_run(text, "back.csv");
  ASSERT_EQ(back.dL_m.size(), r.dL_m.size());
  for (std::size_t i = 0; i < r.dL_m.size(); ++i) EXPECT_DOUBLE_EQ(back.dL_m[i], r.dL_m[i]);
  EXPECT_TRUE(back.extra_columns.empty());
  r.extra_columns[1].second.pop_back();
  try {
    (void)guideway::formats::format_dbb_run(r);
    ADD_FAILURE() << "a short column was written";
  } catch (const guideway::formats::DbbRunFormatError& e) {
    EXPECT_NE(std::string(e.what()).find("column y_cmd_mm has 360 values for 361 samples"), std::string::npos)
        << e.what();
  }
}
TEST(DbbRunTest, TooFewPoints) {
  EXPECT_NE(error_of(header() + rows(20)).find("too few samples: 20, need at least 72"), std::string::npos)
      << error_of(header() + rows(20));
}

TEST(DbbRunTest, PartialArcOf180DegOrMoreIsARun) {
  EXPECT_EQ(error_of(header() + rows(300, 270.0)), "");
  EXPECT_EQ(error_of(header("# data_arc_deg = 220\n") + rows(221, 220.0)), "");
  const auto e = error_of(header() + rows(300, 170.0));
  EXPECT_NE(e.find("partial arc: the samples cover 170.6 deg, a DBB run needs an arc of at least 180 deg"),
            std::string::npos)
      << e;
  const auto stated = error_of(header("# data_arc_deg = 200\n") + rows(300, 270.0));
  EXPECT_NE(stated.find("more than the stated data arc (data_arc_deg = 200.0)"), std::string::npos) << stated;
  const auto small = error_of(header("# data_arc_deg = 120\n") + rows(300, 270.0));
  EXPECT_NE(small.find("data_arc_deg must be between 180 and 360, got 120.0"), std::string::npos) << small;
}

TEST(DbbRunTest, NaNNamesTheLine) {
  std::string text = header() + rows(361);
  const auto pos = text.find("0.05,");
  const auto eol = text.find('\n', pos);
  text.replace(pos, eol - pos, "0.05,5,nan");
  const auto e = error_of(text);
  EXPECT_NE(e.find("run.csv:13: dL_um is not a finite number (nan)"), std::string::npos) << e;
}

TEST(DbbRunTest, MismatchedMetadata) {
  // angles run clockwise but the file says ccw
  auto e = error_of(header() + rows(361, 360.0, -1));
  EXPECT_NE(e.find("angles run clockwise but the metadata says direction = ccw"), std::string::npos) << e;
  // a nominal length that does not fit radius and height
  e = error_of(header("# nominal_length_mm = 105\n") + rows(361));
  EXPECT_NE(e.find("nominal_length_mm = 105 does not match"), std::string::npos) << e;
  // dL of millimetres: the run was recorded with another radius than the metadata says
  std::string big = header();
  for (int i = 0; i <= 360; ++i) big += std::to_string(i * 0.01) + "," + std::to_string(i) + ",5000\n";
  e = error_of(big);
  EXPECT_NE(e.find("the bar length does not match the metadata (radius_mm = 100"), std::string::npos) << e;
  // missing and wrong keys
  e = error_of("# radius_mm = 100\nt_s,angle_deg,dL_um\n" + rows(361));
  EXPECT_NE(e.find("missing metadata line `# format = guideway/dbb-run/1`"), std::string::npos) << e;
  e = error_of(header().replace(header().find("ccw"), 3, "left") + rows(361));
  EXPECT_NE(e.find("run.csv:4: direction must be ccw or cw"), std::string::npos) << e;
  e = error_of(header().replace(header().find("radius_mm = 100"), 15, "radius_mm = abc") + rows(361));
  EXPECT_NE(e.find("run.csv:2: radius_mm: expected a finite number"), std::string::npos) << e;
  e = error_of("# format = guideway/dbb-run/1\nt_s,angle,dL_um\n");
  EXPECT_NE(e.find("header row must name the columns t_s, angle_deg and dL_um"), std::string::npos) << e;
}

TEST(DbbRunTest, IdentifyRefusesMixedPlanesAndEmptyInput) {
  DbbRun a = guideway::formats::parse_dbb_run(header() + rows(361), "a.csv");
  DbbRun b = a;
  b.plane = "xz";
  b.source = "b.csv";
  try {
    (void)identify({a, b});
    FAIL();
  } catch (const guideway::formats::DbbRunFormatError& e) {
    EXPECT_NE(std::string(e.what()).find("b.csv: plane xz differs from a.csv"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)identify({}), guideway::formats::DbbRunFormatError);
  // A run edited in memory is validated as well.
  a.dL_m[5] = std::nan("");
  EXPECT_THROW((void)identify({a}), guideway::formats::DbbRunFormatError);
}

// The runs are fine; what is fitted beside them is not: the solver's failure has its own error, and a column
// of the wrong size is the caller's, neither a run format error.
TEST(DbbRunTest, IdentifySaysWhenAFitCannotBeSolvedAndWhenABesideColumnDoesNotFit) {
  const DbbRun a = guideway::formats::parse_dbb_run(header() + rows(361), "a.csv");
  IdentifyOptions o;
  o.beside.push_back({"thermal_drift", {"drift_um_per_s"}, {std::vector<double>(361, 1.0)}});
  o.beside.front().columns_um.front()[100] = std::nan("");
  try {
    (void)identify({a}, o);
    FAIL();
  } catch (const guideway::formats::DbbRunFormatError& e) {
    FAIL() << "a solver failure read as the runs' format: " << e.what();
  } catch (const FitError& e) {
    EXPECT_NE(std::string(e.what()).find("non-finite"), std::string::npos) << e.what();
  }
  o.beside.front().columns_um.front().resize(360, 1.0);
  try {
    (void)identify({a}, o);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("360 values for 361 samples"), std::string::npos) << e.what();
  }
}

TEST(DbbRunTest, JsonShape) {
  const DbbRun a = guideway::formats::parse_dbb_run(header() + rows(721), "a.csv");
  const auto j = to_json(identify({a}));
  EXPECT_EQ(j["model"], "lai3+ballbar");
  EXPECT_EQ(j["runs"].size(), 1u);
  EXPECT_TRUE(j["diagnostics"].contains("center_offset_x_um"));
  EXPECT_NEAR(j["diagnostics"]["center_offset_x_um"]["value"].get<double>(), 2.0, 1e-6);
  EXPECT_TRUE(j["diagnostics"]["center_offset_x_um"].contains("u"));
  EXPECT_FALSE(j["diagnostics"]["circular_deviation_um"].contains("u"));  // not a fitted value
  EXPECT_TRUE(j["lai3"].contains("e_x_um"));
  for (const char* k : {"rms_um", "n", "condition_number", "unidentifiable"}) EXPECT_TRUE(j["fit"].contains(k)) << k;
}

}  // namespace
