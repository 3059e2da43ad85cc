// core/csv_table: metadata, header detection, delimiters, number columns, errors with file:line.
#include <gtest/gtest.h>

#include "core/csv_table.hpp"
#include "test_support.hpp"

#include <fstream>

namespace guideway {
namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const CsvError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(CsvTable, MetadataHeaderAndColumns) {
  const auto t = parse_csv_table(
      "\xEF\xBB\xBF# format = guideway/raw/1\r\n# device = c\n#plain comment\n\nt_s, z_m ,flags\n0,1.5,0\n1,-2e-6,\n"
      "# end = complete\n",
      "rec.csv");
  EXPECT_EQ(t.metadata.at("format"), "guideway/raw/1");
  EXPECT_EQ(t.metadata.at("device"), "c");
  EXPECT_EQ(t.metadata.at("end"), "complete");
  EXPECT_EQ(t.columns, (std::vector<std::string>{"t_s", "z_m", "flags"}));
  EXPECT_EQ(t.header_line, 5u);
  ASSERT_EQ(t.row_count(), 2u);
  EXPECT_EQ(t.rows[1].line, 7u);
  EXPECT_EQ(t.numbers("z_m"), (std::vector<double>{1.5, -2e-6}));
  EXPECT_EQ(error_of([&] { (void)t.numbers("flags"); }), "rec.csv:7: column 'flags': empty cell");
  EXPECT_EQ(error_of([&] { (void)t.column("x"); }), "rec.csv:5: no column 'x' (columns: 't_s', 'z_m', 'flags')");
  EXPECT_EQ(t.select_column(std::string("z_m")), 1u);
  EXPECT_NE(error_of([&] { (void)t.select_column(std::nullopt); }).find("choose one with --column"), std::string::npos);
  EXPECT_THROW((void)t.metadata_number("device"), CsvError);
  EXPECT_FALSE(t.optional_metadata_number("nope").has_value());
}

TEST(CsvTable, NumberPerLineAndOtherDelimiters) {
  const auto one = parse_csv_table("# unit = m\n1\n2.5\n  -3e2  \n", "n.txt");
  EXPECT_EQ(one.columns, std::vector<std::string>{"value"});
  EXPECT_EQ(one.header_line, 0u);
  EXPECT_EQ(one.numbers(0), (std::vector<double>{1, 2.5, -300}));
  const auto tabs = parse_csv_table("a\tb\n1\t2\n", "t.tsv");
  EXPECT_EQ(tabs.numbers("b"), std::vector<double>{2});
  const auto blanks = parse_csv_table("1  2\n3 4\n", "b.txt");
  EXPECT_EQ(blanks.columns, (std::vector<std::string>{"column1", "column2"}));
  EXPECT_EQ(blanks.numbers("column2"), (std::vector<double>{2, 4}));
}

TEST(CsvTable, ErrorsNameFileAndLine) {
  EXPECT_EQ(error_of([] { (void)parse_csv_table("a,b\n1,2\n3\n", "f.csv"); }),
            "f.csv:3: 1 cells, expected 2 (the header's columns)");
  EXPECT_EQ(error_of([] { (void)parse_csv_table("a,a\n1,2\n", "f.csv"); }),
            "f.csv:1: column 'a' appears twice in the header");
  EXPECT_EQ(error_of([] { (void)parse_csv_table("# only = metadata\n", "f.csv"); }), "f.csv: no header and no data");
  const auto t = parse_csv_table("1\nnan\n", "f.csv");
  EXPECT_EQ(error_of([&] { (void)t.numbers(0); }), "f.csv:2: column 'value': 'nan' is not a finite number");
  EXPECT_NE(error_of([] { (void)read_csv_table("/nonexistent/x.csv"); }).find("/nonexistent/x.csv: cannot read"),
            std::string::npos);
  test::TempDir dir;
  std::ofstream(dir.file("p.csv")) << "z_m\n1\n2\n";
  EXPECT_EQ(read_csv_table(dir.file("p.csv")).numbers("z_m"), (std::vector<double>{1, 2}));
  EXPECT_FALSE(parse_double("1.5x").has_value());
  EXPECT_FALSE(parse_double("inf").has_value());
  EXPECT_EQ(parse_double(" +2 ").value(), 2.0);
}

}  // namespace
}  // namespace guideway
