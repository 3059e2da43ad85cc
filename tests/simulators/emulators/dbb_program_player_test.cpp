// The DBB emulator's program player (can_serial_machine_sources.hpp): a retarget (guidewayd telling the emulated
// machine the session's feed) changes the circles from the next one on, where the last one ended, and leaves the
// circle being traced as it was; the same feed changes nothing.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <memory>

#include "simulators/emulators/can_serial_machine_sources.hpp"

using namespace guideway;
using simulators::emulators::DbbProgramPlayer;
namespace machine = simulators::machine;

namespace {

constexpr double pause_s = 0.5;

// The standard test's two circles (ccw then cw at h = 0 in XY), fast, as `guideway-emulate dbb --program
// standard` makes them.
std::vector<machine::DbbCircleSpec> standard(double feed_m_per_s) {
  machine::DbbCircleSpec ccw;
  ccw.radius_m = 0.1;
  ccw.feed_m_per_s = feed_m_per_s;
  ccw.sample_rate_hz = 1000.0;
  machine::DbbCircleSpec cw = ccw;
  cw.direction = formats::DbbDirection::cw;
  return {ccw, cw};
}

std::array<double, 4> at(DbbProgramPlayer& p, double t_s) {
  std::array<double, 4> out{};
  p.at(t_s, out);
  return out;
}

double circle_s(const machine::Machine& m, const machine::DbbCircleSpec& spec) {
  return simulators::emulators::make_dbb_motion(m, spec)->duration_s;
}

}  // namespace

TEST(DbbProgramPlayer, TheSameFeedAgainChangesNothing) {
  const machine::Machine m(simulators::emulators::demo_machine_config());
  DbbProgramPlayer told(m, standard(0.5), pause_s), alone(m, standard(0.5), pause_s);
  (void)at(told, 0.1);
  told.retarget(0.5);
  for (double t = 0.1; t < 12.0; t += 0.0137) ASSERT_EQ(at(told, t), at(alone, t)) << t;
}

TEST(DbbProgramPlayer, ANewFeedStartsAtTheNextCircleWhereTheLastEnded) {
  const machine::Machine m(simulators::emulators::demo_machine_config());
  DbbProgramPlayer told(m, standard(0.5), pause_s), alone(m, standard(0.5), pause_s);
  const double first_s = circle_s(m, standard(0.5)[0]);
  ASSERT_GT(first_s, 1.0);
  (void)at(told, 0.3);  // tracing the first circle
  told.retarget(0.25);
  // The circle being traced ends as it began, and its pause is kept.
  for (double t = 0.3; t < first_s + pause_s - 1e-3; t += 0.0071) ASSERT_EQ(at(told, t), at(alone, t)) << t;
  // The next circle (the cw one) starts where the program's own next circle starts: no jump of the axes but
  // the program's (the drives' lag at the first circle's end).
  const double boundary_s = first_s + pause_s;
  const auto program = at(alone, boundary_s + 1e-4), after = at(told, boundary_s + 1e-4);
  EXPECT_NEAR(after[1], program[1], 1e-5);
  EXPECT_NEAR(after[2], program[2], 1e-5);
  // ... at half the feed: twice as long, moving until then and standing still in its pause after.
  const double slow_s = circle_s(m, standard(0.25)[1]);
  EXPECT_NEAR(slow_s, 2 * circle_s(m, standard(0.5)[1]), 0.01);
  const auto moved = [&](double t) {
    const auto a = at(told, t), b = at(told, t + 0.01);
    return std::hypot(b[1] - a[1], b[2] - a[2]) / 0.01;
  };
  EXPECT_NEAR(moved(boundary_s + 0.5 * slow_s), 0.25, 0.02);
  EXPECT_NEAR(moved(boundary_s + 0.9 * slow_s), 0.25, 0.02);
  EXPECT_LT(moved(boundary_s + slow_s + 0.1), 0.01);
  // And the program goes on at that feed: the ccw circle after it is as slow.
  const double next_s = boundary_s + slow_s + pause_s;
  EXPECT_NEAR(moved(next_s + 0.5 * slow_s), 0.25, 0.02);
  EXPECT_LT(moved(next_s + slow_s + 0.1), 0.01);
}

TEST(DbbProgramPlayer, ARadiusGivenIsTheNextCirclesBar) {
  const machine::Machine m(simulators::emulators::demo_machine_config());
  DbbProgramPlayer told(m, standard(0.5), pause_s);
  const double first_s = circle_s(m, standard(0.5)[0]);
  // The bar's length: the radius at h = 0, within the demo machine's errors at 30 m/min (0.4 mm).
  EXPECT_NEAR(at(told, 0.2)[0], 0.1, 1e-3);
  told.retarget(0.5, 0.15);
  EXPECT_NEAR(at(told, first_s)[0], 0.1, 1e-3);
  EXPECT_NEAR(at(told, first_s + pause_s + 0.5)[0], 0.15, 1e-3);
  EXPECT_NEAR(at(told, first_s + pause_s + 3.0)[0], 0.15, 1e-3);
}
