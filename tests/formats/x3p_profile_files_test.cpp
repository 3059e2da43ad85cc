// Profile files: the real X3P sample checked against an independent read (/usr/bin/python3 with
// zipfile + numpy), X3P and CSV round trips, CSV errors with file:line, and a randomized test of the
// X3P/zip and CSV readers on mutated input (>= 100k inputs: they either read it or throw ProfileFileError).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <sstream>

#include "formats/profile_files.hpp"
#include "test_support.hpp"

using namespace guideway::formats;

namespace {

const std::string sample_x3p = std::string(GUIDEWAY_TEST_DATA_DIR) + "/x3p/sample-land.x3p";

std::string run(const std::string& command) {
  std::string out;
  FILE* p = popen(command.c_str(), "r");
  if (!p) return out;
  char buf[4096];
  while (std::size_t n = fread(buf, 1, sizeof(buf), p)) out.append(buf, n);
  pclose(p);
  return out;
}

double nanmean(const std::vector<double>& v) {
  double sum = 0;
  std::size_t n = 0;
  for (double z : v) {
    if (!std::isnan(z)) {
      sum += z;
      ++n;
    }
  }
  return n ? sum / static_cast<double>(n) : std::nan("");
}

X3pSurface small_surface(std::size_t sx, std::size_t sy) {
  X3pSurface s;
  s.feature_type = "SUR";
  s.size_x = sx;
  s.size_y = sy;
  s.size_z = 1;
  s.increment_x_m = 0.5e-6;
  s.increment_y_m = 10e-6;
  s.offset_x_m = 1e-3;
  for (std::size_t i = 0; i < sx * sy; ++i)
    s.z_m.push_back(i % 7 == 3 ? std::nan("") : 1e-7 * std::sin(0.1 * static_cast<double>(i)));
  return s;
}

}  // namespace

TEST(X3p, RealSampleMatchesAnIndependentRead) {
  const std::string oracle = run("/usr/bin/python3 " + std::string(GUIDEWAY_SOURCE_DIR) +
                                 "/tests/formats/x3p_oracle.py " + sample_x3p + " 2>&1");
  ASSERT_NE(oracle.find("size_x"), std::string::npos) << oracle;
  const X3pSurface s = read_x3p(sample_x3p);
  EXPECT_EQ(s.feature_type, "SUR");
  EXPECT_EQ(s.data_type, 'D');
  std::istringstream in(oracle);
  std::string key;
  int checked = 0;
  while (in >> key) {
    if (key == "size_x" || key == "size_y") {
      std::size_t v;
      in >> v;
      EXPECT_EQ(key == "size_x" ? s.size_x : s.size_y, v) << key;
    } else if (key == "increment_x" || key == "increment_y") {
      double v;
      in >> v;
      EXPECT_EQ(key == "increment_x" ? s.increment_x_m : s.increment_y_m, v) << key;
    } else if (key == "data_type") {
      std::string t;
      in >> t;
      EXPECT_EQ(std::string(1, s.data_type), t);
    } else if (key == "nan_count") {
      std::size_t n;
      in >> n;
      std::size_t ours = 0;
      for (double z : s.z_m) ours += std::isnan(z) ? 1 : 0;
      EXPECT_EQ(ours, n);
    } else if (key == "row_nanmean") {
      std::size_t iy;
      std::string v;
      in >> iy >> v;
      const Profile row = x3p_row(s, iy);
      EXPECT_NEAR(nanmean(row.z_m), std::stod(v), 1e-12 * std::abs(std::stod(v)) + 1e-18) << "row " << iy;
    } else if (key == "z") {
      std::size_t ix, iy;
      std::string v;
      in >> ix >> iy >> v;
      if (v == "nan") {
        EXPECT_TRUE(std::isnan(s.at(ix, iy)));
      } else {
        EXPECT_EQ(s.at(ix, iy), std::stod(v)) << ix << "," << iy;  // bit-exact float64
      }
    } else {
      FAIL() << "unexpected oracle output: " << key;
    }
    ++checked;
  }
  EXPECT_EQ(checked, 14);
  // Rows as profiles: 256 profiles of 918 points, 2.58 um apart.
  const auto profiles = read_profiles(sample_x3p);
  ASSERT_EQ(profiles.size(), 256u);
  EXPECT_EQ(profiles[10].x_m.size(), 918u);
  ASSERT_TRUE(profiles[10].spacing_m());
  EXPECT_NEAR(*profiles[10].spacing_m(), 2.58e-6, 1e-15);
  EXPECT_EQ(profiles[10].meta("row"), "10");
  EXPECT_EQ(profiles[10].meta("instrument_manufacturer"), "Sensofar");
}

TEST(X3p, BuildsAndReadsBackStoredAndDeflated) {
  const X3pSurface s = small_surface(37, 5);
  for (bool deflate : {false, true}) {
    const X3pSurface back = parse_x3p(build_x3p(s, deflate), "mem.x3p");
    ASSERT_EQ(back.size_x, 37u);
    ASSERT_EQ(back.size_y, 5u);
    EXPECT_EQ(back.increment_x_m, 0.5e-6);
    EXPECT_EQ(back.offset_x_m, 1e-3);
    for (std::size_t i = 0; i < s.z_m.size(); ++i) {
      if (std::isnan(s.z_m[i])) {
        EXPECT_TRUE(std::isnan(back.z_m[i]));
      } else {
        EXPECT_EQ(back.z_m[i], s.z_m[i]);
      }
    }
  }
  EXPECT_THROW(parse_x3p("not a zip at all, just text long enough", "bad.x3p"), ProfileFileError);
}

TEST(ProfileCsv, ReadsMetadataUnitsAndInvalidPoints) {
  const Profile p = parse_profile_csv(
      "# format = guideway/profile/1\n# feed_mm_per_min = 2.0\n# spindle_rpm = 100\n# a comment without equals\n"
      "x_mm,z_um,extra\n0.000,0.25,a\n0.0005,-0.5,b\n0.001,,c\n0.0015,nan,d\n# end = complete\n",
      "p.csv");
  ASSERT_EQ(p.x_m.size(), 4u);
  EXPECT_DOUBLE_EQ(p.x_m[1], 0.5e-6);
  EXPECT_DOUBLE_EQ(p.z_m[1], -0.5e-6);
  EXPECT_TRUE(std::isnan(p.z_m[2]));
  EXPECT_TRUE(std::isnan(p.z_m[3]));
  EXPECT_EQ(p.meta("feed_mm_per_min"), "2.0");
  EXPECT_EQ(p.meta("spindle_rpm"), "100");
  EXPECT_EQ(p.meta("end"), "complete");
  ASSERT_TRUE(p.spacing_m());
  EXPECT_NEAR(*p.spacing_m(), 0.5e-6, 1e-15);
  const Profile um = parse_profile_csv("x_um,z_nm\n1,2\n", "u.csv");
  EXPECT_DOUBLE_EQ(um.x_m[0], 1e-6);
  EXPECT_DOUBLE_EQ(um.z_m[0], 2e-9);
}

TEST(ProfileCsv, ErrorsNameFileAndLine) {
  auto message = [](const std::string& text) {
    try {
      parse_profile_csv(text, "bad.csv");
    } catch (const ProfileFileError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(message("# a = b\nx,z\n1,2\n"),
            "bad.csv:2: expected a header row naming x and z with units, e.g. x_mm,z_um");
  EXPECT_EQ(message("x_mm,z_um\n1,2\n3,oops\n"), "bad.csv:3: z is not a number");
  EXPECT_EQ(message("x_mm,z_um\n1,2,3\n"), "bad.csv:2: expected 2 columns, got 3");
  EXPECT_NE(message("x_mm,z_um\n").find("no data rows"), std::string::npos);
}

TEST(ProfileCsv, WritesAndReadsBackThroughAFile) {
  guideway::test::TempDir dir;
  Profile p;
  p.metadata = {{"feed_mm_per_min", "2"}, {"spindle_rpm", "100"}};
  for (int i = 0; i < 100; ++i) {
    p.x_m.push_back(i * 0.5e-6);
    p.z_m.push_back(i == 50 ? std::nan("") : 1e-7 * std::cos(i * 0.3));
  }
  write_profile_csv(dir.file("p.csv"), p);
  const auto back = read_profiles(dir.file("p.csv"));
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].meta("format"), "guideway/profile/1");
  EXPECT_EQ(back[0].meta("spindle_rpm"), "100");
  ASSERT_EQ(back[0].z_m.size(), 100u);
  for (int i = 0; i < 100; ++i) {
    EXPECT_NEAR(back[0].x_m[i], p.x_m[i], 1e-18);
    if (i == 50) {
      EXPECT_TRUE(std::isnan(back[0].z_m[i]));
    } else {
      EXPECT_NEAR(back[0].z_m[i], p.z_m[i], 1e-21);
    }
  }
}

TEST(ProfileFiles, RandomizedMutationsEitherReadOrThrowProfileFileError) {
  std::mt19937_64 rng(5436);
  const std::string stored = build_x3p(small_surface(6, 3), false);
  const std::string deflated = build_x3p(small_surface(6, 3), true);
  const std::string csv = "# feed_mm_per_min = 2\nx_mm,z_um\n0,1\n0.001,2.5\n0.002,\n0.003,-1e-3\n";
  std::size_t inputs = 0, read_ok = 0;
  for (int iter = 0; iter < 120000; ++iter) {
    std::string s = iter % 3 == 0 ? stored : iter % 3 == 1 ? deflated : csv;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits && !s.empty(); ++e) {
      const std::size_t at = rng() % s.size();
      switch (rng() % 4) {
        case 0:
          s[at] = static_cast<char>(rng());
          break;
        case 1:
          s[at] = static_cast<char>(s[at] ^ (1 << (rng() % 8)));
          break;
        case 2:
          s.erase(at, 1 + rng() % 16);
          break;
        default:
          s.resize(at);
          break;  // truncated file
      }
    }
    ++inputs;
    try {
      if (iter % 3 == 2) {
        const Profile p = parse_profile_csv(s, "fuzz.csv");
        ASSERT_EQ(p.x_m.size(), p.z_m.size());
      } else {
        const X3pSurface x = parse_x3p(s, "fuzz.x3p");
        ASSERT_EQ(x.z_m.size(), x.size_x * x.size_y);
        (void)x3p_profiles(x);
      }
      ++read_ok;
    } catch (const ProfileFileError&) {
    }
  }
  EXPECT_GE(inputs, 100000u);
  EXPECT_GT(read_ok, 100u);  // some mutations are harmless (metadata bytes, CSV digits)
}
