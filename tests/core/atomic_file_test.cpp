// core/atomic_file: a set of files written as one (issue 46 item 14: a rename failing half way left the
// new x.comp beside the old rest).
#include "core/atomic_file.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "test_support.hpp"

namespace guideway {
namespace {

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(AtomicFileSet, ARenameThatFailsHalfWayLeavesTheEarlierSetWhole) {
  test::TempDir dir;
  write_file_set_atomically(dir.path().string(), {{"x.comp", "old x"}, {"y.comp", "old y"}, {"straightness.csv", "old s"}}, {});
  // y.comp's rename will fail: a directory, not empty, took its place (EISDIR / ENOTEMPTY).
  std::filesystem::remove(dir.file("y.comp"));
  std::filesystem::create_directories(dir.file("y.comp/inside"));
  EXPECT_THROW(write_file_set_atomically(dir.path().string(), {{"x.comp", "new x"}, {"y.comp", "new y"}, {"errors.csv", "new e"}},
                                         {"x.comp", "y.comp", "errors.csv", "straightness.csv"}),
               std::runtime_error);
  EXPECT_EQ(read(dir.file("x.comp")), "old x");
  EXPECT_EQ(read(dir.file("straightness.csv")), "old s");
  EXPECT_FALSE(std::filesystem::exists(dir.file("errors.csv")));
  for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
    const std::string name = e.path().filename().string();
    EXPECT_FALSE(name.ends_with(".part") || name.ends_with(".previous")) << name;
  }
}

TEST(AtomicFileSet, ANewSetReplacesTheOldAndRetiresWhatItLacks) {
  test::TempDir dir;
  write_file_set_atomically(dir.path().string(), {{"x.comp", "old x"}, {"straightness.csv", "old s"}}, {});
  write_file_set_atomically(dir.path().string(), {{"x.comp", "new x"}, {"y.comp", "new y"}},
                            {"x.comp", "y.comp", "straightness.csv"});
  EXPECT_EQ(read(dir.file("x.comp")), "new x");
  EXPECT_EQ(read(dir.file("y.comp")), "new y");
  EXPECT_FALSE(std::filesystem::exists(dir.file("straightness.csv")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.comp.previous")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("straightness.csv.previous")));
}

}  // namespace
}  // namespace guideway
