// The DABAM reader (formats/dabam): entries as the database stores them (header lines, column indices,
// factors with their signs, quoted or empty metadata values, decreasing abscissae), every refusal naming its
// file and line, a real entry read whole, and a property test: random valid entries read back exactly,
// random damage to them gives a value or a CsvError, never anything else.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "core/csv_table.hpp"
#include "formats/dabam.hpp"

namespace {

using guideway::CsvError;
using guideway::formats::parse_dabam;

std::string error_of(const std::string& dat, const std::string& txt) {
  try {
    (void)parse_dabam(dat, txt, "e.dat", "e.txt");
  } catch (const CsvError& e) {
    return e.what();
  }
  return "no error";
}

const std::string meta = R"({"FILE_FORMAT": 1, "FILE_HEADER_LINES": 1, "X1_FACTOR": 0.001, "Y1_FACTOR": 1e-06,
  "LENGTH": "", "SURFACE_SHAPE": 1, "FACILITY": "ESRF", "INSTRUMENT": null})";

TEST(DabamReader, ColumnsFactorsSignsAndOrderAsTheMetadataStatesThem) {
  // Columns: slope (urad, its sign flipped by Y1_FACTOR), a spare, x (mm); listed from +x to -x.
  const std::string txt = R"({"FILE_FORMAT": 3, "FILE_HEADER_LINES": 2, "COLUMN_INDEX_ABSCISSA": 2,
    "COLUMN_INDEX_ORDINATE": 0, "X1_FACTOR": "0.001", "Y1_FACTOR": -1e-6, "LENGTH": 0.12})";
  const auto p = parse_dabam("# x slope\n# two header lines\n1.5 9 10\n\n-2\t9\t5\n0.25 9 0\n", txt, "e.dat", "e.txt");
  ASSERT_EQ(p.x_m.size(), 3u);
  EXPECT_DOUBLE_EQ(p.x_m[0], 0.0);
  EXPECT_DOUBLE_EQ(p.x_m[2], 0.010);
  EXPECT_DOUBLE_EQ(p.slope_rad[0], -0.25e-6);
  EXPECT_DOUBLE_EQ(p.slope_rad[1], 2e-6);
  EXPECT_DOUBLE_EQ(p.slope_rad[2], -1.5e-6);
  EXPECT_EQ(p.line[0], 6u);
  EXPECT_EQ(p.line[2], 3u);
  EXPECT_EQ(p.file_format, 3);
  EXPECT_DOUBLE_EQ(p.length_m, 0.12);
  // An empty or null value is not stated (some entries have LENGTH ""); a bare number is text.
  const auto q = parse_dabam("h\n0 1\n1 2\n", meta, "e.dat", "e.txt");
  EXPECT_TRUE(std::isnan(q.length_m));
  EXPECT_EQ(q.surface_shape, "1");
  EXPECT_EQ(q.facility, "ESRF");
  EXPECT_EQ(q.instrument, "");
}

TEST(DabamReader, RefusalsNameTheFileAndLine) {
  EXPECT_EQ(error_of("h\n0 1\n1 2\n", R"({"FILE_FORMAT": 2, "X1_FACTOR": 1, "Y1_FACTOR": 1})"),
            "e.txt: FILE_FORMAT = 2 is a height profile; only slope profiles (FILE_FORMAT 1 or 3) are read");
  EXPECT_EQ(error_of("h\n0 1\n1 2\n", R"({"FILE_FORMAT": 1, "Y1_FACTOR": 1})"),
            "e.txt: X1_FACTOR is missing (a DABAM entry's metadata states it)");
  EXPECT_EQ(error_of("h\n0 1\n1 2\n", "[1, 2]"), "e.txt: not DABAM metadata (a JSON object)");
  EXPECT_EQ(error_of("h\n0 1\n1 x\n", meta), "e.dat:3: 'x' is not a number (after 1 header line(s))");
  EXPECT_EQ(error_of("h\n0 1\n1\n", meta),
            "e.dat:3: 1 column(s); the metadata needs 2 (abscissa column 0, profile column 1)");
  EXPECT_EQ(error_of("h\n0 1\n2 2\n1 3\n", meta), "e.dat:4: x = 0.001 m does not increase (previous 0.002 m)");
  EXPECT_EQ(error_of("h\n0 1\n1 200000\n", meta),
            "e.dat:3: slope = 0.2 rad is outside +-0.1 rad (a slope profile's plausible bound)");
  EXPECT_EQ(error_of("h\n0 1\n", meta), "e.dat: 1 reading(s) after 1 header line(s); a profile needs at least 2");
  EXPECT_EQ(error_of("h\n0 1\n1 2\n", R"({"FILE_FORMAT": 1, "X1_FACTOR": 0, "Y1_FACTOR": 1})"),
            "e.txt: X1_FACTOR = 0 is outside +-[1e-12, 1e3] (the abscissa's unit in metres)");
}

TEST(DabamReader, ARealEntryIsReadWhole) {
  const auto p = guideway::formats::read_dabam(std::string(GUIDEWAY_TEST_DATA_DIR) + "/dabam/dabam-004.txt");
  ASSERT_EQ(p.x_m.size(), 161u);
  EXPECT_EQ(p.source, std::string(GUIDEWAY_TEST_DATA_DIR) + "/dabam/dabam-004.dat");
  for (std::size_t i = 1; i < p.x_m.size(); ++i) ASSERT_GT(p.x_m[i], p.x_m[i - 1]);
  try {
    (void)guideway::formats::read_dabam("/nonexistent/dabam-000.dat");
    ADD_FAILURE() << "no error";
  } catch (const CsvError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dabam-000.dat"), std::string::npos) << e.what();
  }
}

// Random entries (header lines, column layout, factors and their signs, order) read back exactly; random
// damage (a byte changed, a line cut, the metadata cut) gives a profile or a CsvError naming the file.
TEST(DabamReader, PropertyRandomEntriesAndDamage) {
  std::mt19937_64 rng(41);
  std::uniform_int_distribution<int> small(0, 3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int refused = 0, read = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int header = small(rng), columns = 2 + small(rng);
    const int cx = small(rng) % columns;
    const int cy = (cx + 1 + small(rng) % (columns - 1)) % columns;
    const double xf = trial % 2 ? 1e-3 : 1.0, yf = (trial % 3 ? 1e-6 : 1e-3) * (trial % 5 ? 1 : -1);
    const bool decreasing = trial % 7 == 0;
    const std::size_t n = 2 + static_cast<std::size_t>(trial % 40);
    std::string dat;
    for (int h = 0; h < header; ++h) dat += "# header " + std::to_string(h) + "\n";
    std::vector<double> xs(n), ys(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t k = decreasing ? n - 1 - i : i;
      xs[k] = 0.5 * static_cast<double>(k) + 0.01 * u(rng) - 7.0;
      ys[k] = 40.0 * u(rng);
    }
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t k = decreasing ? n - 1 - i : i;
      char cell[64];
      for (int c = 0; c < columns; ++c) {
        std::snprintf(cell, sizeof cell, "%.17g", c == cx ? xs[k] : c == cy ? ys[k] : 1.0);
        dat += std::string(c ? (trial % 2 ? "\t" : "   ") : "") + cell;
      }
      dat += "\n";
    }
    char txt[512];
    std::snprintf(txt, sizeof txt,
                  R"({"FILE_FORMAT": 1, "FILE_HEADER_LINES": %d, "COLUMN_INDEX_ABSCISSAS": %d, )"
                  R"("COLUMN_INDEX_ORDINATES": %d, "X1_FACTOR": %.17g, "Y1_FACTOR": %.17g})",
                  header, cx, cy, xf, yf);
    const auto p = parse_dabam(dat, txt, "e.dat", "e.txt");
    ASSERT_EQ(p.x_m.size(), n) << trial;
    for (std::size_t k = 0; k < n; ++k) {
      ASSERT_EQ(p.x_m[k], xs[k] * xf) << trial;
      ASSERT_EQ(p.slope_rad[k], ys[k] * yf) << trial;
    }
    for (int damage = 0; damage < 10; ++damage) {
      std::string d = dat, t = txt;
      std::uniform_int_distribution<std::size_t> at(0, d.size() - 1);
      switch (damage % 3) {
        case 0:
          d[at(rng)] = "x-.e 9\n\t"[small(rng) * 2 + damage % 2];
          break;
        case 1:
          d.resize(at(rng));
          break;
        default:
          t.resize(std::uniform_int_distribution<std::size_t>(0, t.size() - 1)(rng));
          break;
      }
      try {
        (void)parse_dabam(d, t, "e.dat", "e.txt");
        ++read;
      } catch (const CsvError& e) {
        ++refused;
        const std::string what = e.what();
        EXPECT_TRUE(what.starts_with("e.dat") || what.starts_with("e.txt")) << what;
      }
    }
  }
  std::printf("damaged entries: %d read, %d refused with a message\n", read, refused);
  EXPECT_GT(refused, 0);
  EXPECT_GT(read, 0);
}

}  // namespace
