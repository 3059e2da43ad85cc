// models/dbb/fast_sincos.hpp against libm's std::sin/std::cos: absolute error and ulps over the
// documented range (|x| <= 1e6), at the quadrant boundaries and at exact zeros.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include "models/dbb/fast_sincos.hpp"

namespace {

using guideway::models::dbb::fast_sincos;
using guideway::models::dbb::fast_sincos_batch;

// Distance in units of the last place of the larger magnitude (at least the ulp of 1e-300 apart).
double ulps(double a, double b) {
  const double m = std::max({std::abs(a), std::abs(b), 1e-300});
  return std::abs(a - b) / (std::nextafter(m, 2 * m) - m);
}

void check(double x, double& worst_abs, double& worst_ulp) {
  double s = 0, c = 0;
  fast_sincos(x, s, c);
  const double es = std::abs(s - std::sin(x)), ec = std::abs(c - std::cos(x));
  worst_abs = std::max({worst_abs, es, ec});
  // ulps only where the value is not tiny (near a zero an absolute error of 1e-17 is many ulps).
  if (std::abs(std::sin(x)) > 1e-3) worst_ulp = std::max(worst_ulp, ulps(s, std::sin(x)));
  if (std::abs(std::cos(x)) > 1e-3) worst_ulp = std::max(worst_ulp, ulps(c, std::cos(x)));
}

TEST(DbbFastSincos, AgreesWithLibmOverTheDocumentedRange) {
  std::mt19937_64 rng(5);
  double worst_abs = 0, worst_ulp = 0;
  for (double scale : {1.0, 10.0, 1e3, 1e6}) {
    std::uniform_real_distribution<double> u(-scale, scale);
    for (int i = 0; i < 200000; ++i) check(u(rng), worst_abs, worst_ulp);
  }
  EXPECT_LE(worst_abs, 4e-16);
  EXPECT_LE(worst_ulp, 2.0);
}

TEST(DbbFastSincos, LibmBeyondTheRangeAndForNonFinite) {
  double s = 0, c = 0;
  fast_sincos(3e7, s, c);
  EXPECT_EQ(s, std::sin(3e7));
  EXPECT_EQ(c, std::cos(3e7));
  fast_sincos(NAN, s, c);
  EXPECT_TRUE(std::isnan(s) && std::isnan(c));
}

TEST(DbbFastSincos, QuadrantBoundariesAndSigns) {
  double worst_abs = 0, worst_ulp = 0;
  for (int k = -4000; k <= 4000; ++k) {
    const double x = k * (std::numbers::pi / 4);
    for (double d : {-1e-9, 0.0, 1e-9}) check(x + d, worst_abs, worst_ulp);
  }
  EXPECT_LE(worst_abs, 4e-16);
  EXPECT_LE(worst_ulp, 2.0);
  double s = 1, c = 0;
  fast_sincos(0.0, s, c);
  EXPECT_EQ(s, 0.0);
  EXPECT_EQ(c, 1.0);
  fast_sincos(-std::numbers::pi / 2, s, c);
  EXPECT_NEAR(s, -1.0, 1e-16);
  EXPECT_NEAR(c, 0.0, 1e-16);
}

// The batch is the one-by-one function bit for bit (EXPLAIN's results must not move with it): a vector at a time
// where every argument is in range, and a batch holding one outside (beyond 1e6, infinite, NaN) element by element.
TEST(DbbFastSincos, TheBatchIsOneByOneBitForBit) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> exponent(-9.0, 6.0), sign(-1.0, 1.0);
  std::vector<double> x(4099);
  for (double& v : x) v = sign(rng) * std::pow(10.0, exponent(rng));
  for (int k = 0; k < 64; ++k) x[static_cast<std::size_t>(k)] = (k - 32) * (std::numbers::pi / 4);
  x[100] = 0.0;
  x[101] = -0.0;
  x[102] = 1e6;
  x[103] = -1e6;
  const auto same = [](double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; };
  const auto check = [&](const std::vector<double>& in) {
    std::vector<double> s(in.size()), c(in.size());
    fast_sincos_batch(in.data(), s.data(), c.data(), in.size());
    for (std::size_t i = 0; i < in.size(); ++i) {
      double s1 = 0, c1 = 0;
      fast_sincos(in[i], s1, c1);
      ASSERT_TRUE(same(s[i], s1) && same(c[i], c1)) << "x = " << in[i];
    }
  };
  check(x);
  for (const double outside : {std::nextafter(1e6, 2e6), 3e7, std::numeric_limits<double>::infinity(),
                             std::numeric_limits<double>::quiet_NaN()}) {
    std::vector<double> with = x;
    with[2000] = outside;
    check(with);
  }
}

}  // namespace
