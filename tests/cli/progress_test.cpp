// A long command's progress lines (cli/progress.hpp): none while its quiet start lasts or when it is quiet;
// a line at once for a new phase, none for the same phase with other numbers (before 5 s), and a new
// phase not sooner than a second after the last line.
#include "cli/progress.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

struct Lines {
  std::mutex mutex;
  std::vector<std::pair<Clock::time_point, std::string>> lines;
  std::function<void(const std::string&)> sink() {
    return [this](const std::string& line) {
      std::lock_guard lock(mutex);
      lines.emplace_back(Clock::now(), line);
    };
  }
  std::pair<Clock::time_point, std::string> line(std::size_t i) {
    std::lock_guard lock(mutex);
    return lines.at(i);
  }
  std::size_t count() {
    std::lock_guard lock(mutex);
    return lines.size();
  }
  // Waits up to 5 s (a loaded machine) for `n` lines.
  bool wait_for(std::size_t n) {
    for (const auto end = Clock::now() + std::chrono::seconds(5); Clock::now() < end;) {
      if (count() >= n) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }
};

}  // namespace

TEST(Progress, APhaseIsPrintedOnceThenTheNextNotSoonerThanASecond) {
  Lines shown, quiet, young;
  guideway::cli::Progress quiet_progress("q", true, 0.0, quiet.sink());
  guideway::cli::Progress young_progress("y", false, 60.0, young.sink());
  quiet_progress.doing("anything");
  young_progress.doing("anything");
  {
    guideway::cli::Progress p("explain", false, 0.0, shown.sink());
    p.doing("looking for effect 1: trying backlash (1 of 14)");
    ASSERT_TRUE(shown.wait_for(1));
    EXPECT_EQ(shown.line(0).second, "  [0 s] explain: looking for effect 1: trying backlash (1 of 14)");
    p.doing("looking for effect 1: trying backlash (2 of 14)");  // the same phase: its numbers only
    std::this_thread::sleep_for(std::chrono::milliseconds(600));
    EXPECT_EQ(shown.count(), 1u);
    p.doing("looking for effect 1: trying vibration (3 of 14)");
    ASSERT_TRUE(shown.wait_for(2));
    EXPECT_NE(shown.line(1).second.find("explain: looking for effect 1: trying vibration (3 of 14)"), std::string::npos)
        << shown.line(1).second;
    EXPECT_GE(shown.line(1).first - shown.line(0).first, std::chrono::seconds(1));
    p.doing("");  // nothing to say: nothing printed until the end
  }
  EXPECT_EQ(shown.count(), 2u);
  EXPECT_EQ(quiet.count(), 0u);
  EXPECT_EQ(young.count(), 0u);
}
