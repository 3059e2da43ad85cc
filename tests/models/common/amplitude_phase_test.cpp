// A line's amplitude and phase from its sine and cosine parts (models/common/amplitude_phase), against numpy.
#include "models/common/amplitude_phase.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using guideway::models::amplitude_phase;

namespace {
constexpr double deg = 180 / std::numbers::pi;
}

// numpy (1.24): the Jacobian of (hypot, arctan2) by central differences (h = 1e-7) at (s, c) = (0.3, -0.4),
// J S J^T with S = [[0.010, 0.006], [0.006, 0.020]]: u(A) = 0.10315037568148769, u(phi) = 15.944294396641219 deg
// (400 000 draws of a multivariate normal: sd 0.1015 and 15.93 deg). Without the covariance the parts' u's in
// quadrature would give 0.1281 and 13.36 deg: the parts of a line fitted beside other terms correlate.
TEST(AmplitudePhase, PropagatesThePartsCovarianceAsNumpy) {
  const auto a = amplitude_phase(0.30, -0.40, 0.010, 0.020, 0.006);
  EXPECT_NEAR(a.amplitude, 0.5, 1e-15);
  EXPECT_NEAR(a.phase_rad * deg, -53.13010235415598, 1e-12);
  EXPECT_NEAR(a.u_amplitude, 0.10315037568148769, 1e-8);
  EXPECT_NEAR(a.u_phase_rad * deg, 15.944294396641219, 1e-6);
  const auto uncorrelated = amplitude_phase(0.30, -0.40, 0.010, 0.020, 0.0);
  EXPECT_NEAR(uncorrelated.u_amplitude, 0.12806248476360968, 1e-8);
  EXPECT_GT(std::abs(uncorrelated.u_phase_rad - a.u_phase_rad) * deg, 2.0);
}

// s sin(theta) + c cos(theta) = A sin(theta + phi) at every theta, in every quadrant.
TEST(AmplitudePhase, IsTheSineWithThePhaseAddedToItsAngle) {
  for (const auto& [s, c] : {std::pair{1.0, 0.0}, {0.0, 1.0}, {-0.7, 0.2}, {-0.3, -1.1}, {0.4, -0.9}}) {
    const auto a = amplitude_phase(s, c, 1e-4, 1e-4, 0.0);
    for (double theta = -3; theta < 3; theta += 0.7)
      EXPECT_NEAR(s * std::sin(theta) + c * std::cos(theta), a.amplitude * std::sin(theta + a.phase_rad), 1e-12);
  }
}

// No line: no amplitude to divide by, so neither u is a number.
TEST(AmplitudePhase, ALineOfZeroAmplitudeHasNoUncertainty) {
  const auto a = amplitude_phase(0.0, 0.0, 1e-4, 1e-4, 0.0);
  EXPECT_EQ(a.amplitude, 0.0);
  EXPECT_TRUE(std::isnan(a.u_amplitude));
  EXPECT_TRUE(std::isnan(a.u_phase_rad));
}
