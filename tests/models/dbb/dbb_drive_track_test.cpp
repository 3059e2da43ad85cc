// models/dbb/geometry.hpp's drive tracks: a track keeps each sample's rise as a float signed by the axis' direction,
// and lost_motion() must give exactly what the deadband gives on the exact rise (deadband_lost_motion of
// drive_rise_m, drive_direction), at every width: those at and within rounding of a rise most of all.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "models/dbb/geometry.hpp"

namespace {

using namespace guideway::models::dbb;

// Two turns of a circle each way, with the angles at the axes' reversals (k pi / 2) exactly among them.
std::vector<SampleGeometry> circles() {
  std::vector<SampleGeometry> g;
  for (const int dir : {1, -1})
    for (int k = 0; k <= 2 * 720; ++k)
      g.push_back(circle_geometry(0.15, 0.01, dir, 1000.0 / 60e3, dir * k * std::numbers::pi / 360));
  return g;
}

TEST(DbbDriveTrack, LostMotionIsTheExactDeadbandsAtEveryWidth) {
  const std::vector<SampleGeometry> g = circles();
  const std::vector<double> delays{0.0, 15e-3, 100e-3};
  const std::vector<DriveTrack> tracks = drive_tracks(g, delays);
  std::mt19937_64 rng(45);
  std::uniform_real_distribution<double> width(0.0, 30e-6);
  std::size_t near = 0;
  for (const DriveTrack& t : tracks)
    for (std::size_t i = 0; i < g.size(); ++i) {
      const double ra = drive_rise_m(g[i], t.delay_s, 0.0), rb = drive_rise_m(g[i], t.delay_s, std::numbers::pi / 2);
      const double va = drive_direction(g[i], t.delay_s, 0.0), vb = drive_direction(g[i], t.delay_s, std::numbers::pi / 2);
      // Widths at each rise, a float's rounding and 1e-6 either side of it, and random ones; none (0) and negative.
      std::vector<double> widths{ra, rb, 0.0, -1e-6, width(rng)};
      for (const double r : {ra, rb})
        for (const double f : {1 - 1e-6, 1 - 6e-8, 1 + 6e-8, 1 + 1e-6, 1 + 2e-6}) widths.push_back(r * f);
      // Between each exact rise and its float: there the float alone would take the deadband up when the exact
      // rise does not, or the other way round.
      widths.push_back(0.5 * (ra + std::abs(static_cast<double>(t.a[i]))));
      widths.push_back(0.5 * (rb + std::abs(static_cast<double>(t.b[i]))));
      widths.push_back(std::nextafter(ra, 1.0));
      for (const double w : widths) {
        const auto m = lost_motion(t, g[i], i, w, w);
        ASSERT_EQ(m[0], deadband_lost_motion(va, ra, w)) << "a, sample " << i << ", width " << w;
        ASSERT_EQ(m[1], deadband_lost_motion(vb, rb, w)) << "b, sample " << i << ", width " << w;
        near += (w > 0 && std::abs(w - ra) < 1e-6 * ra) ? 1 : 0;
      }
    }
  EXPECT_GT(near, g.size());  // the widths within a float's reach of a rise were there
}

// At a reversal the rise is 0 and the direction is the one the axis is about to take: the float keeps it (-0 / +0).
TEST(DbbDriveTrack, TheDirectionAtAReversalIsKept) {
  const std::vector<SampleGeometry> g = circles();
  const std::vector<DriveTrack> tracks = drive_tracks(g, {0.0});
  std::size_t reversals = 0;
  for (std::size_t i = 0; i < g.size(); ++i) {
    const double ra = drive_rise_m(g[i], 0.0, 0.0);
    if (ra != 0.0) continue;
    ++reversals;
    EXPECT_EQ(std::signbit(tracks[0].a[i]), drive_direction(g[i], 0.0, 0.0) < 0) << i;
    EXPECT_EQ(lost_motion(tracks[0], g[i], i, 1e-6, 1e-6)[0], -drive_direction(g[i], 0.0, 0.0) * -0.5) << i;
  }
  EXPECT_GT(reversals, 0u);
}

}  // namespace
