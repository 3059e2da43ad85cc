// Correlation (Mu et al. Eqs. 6, 19, 20), cross-correlation over lags, sliding correlation, degenerate input.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dsp/correlation.hpp"

namespace guideway::dsp {
namespace {

std::vector<double> noise(std::size_t n, double sigma, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, sigma);
  std::vector<double> v(n);
  for (auto& x : v) x = g(rng);
  return v;
}

void expect_error(const std::function<void()>& f, const std::string& words) {
  try {
    f();
    FAIL() << "no error, expected: " << words;
  } catch (const CorrelationError& e) {
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(Pearson, KnownValuesAndDegenerateInput) {
  const std::vector<double> x{1, 2, 3, 4, 5};
  EXPECT_DOUBLE_EQ(pearson(x, std::vector<double>{2, 4, 6, 8, 10}), 1.0);
  EXPECT_DOUBLE_EQ(pearson(x, std::vector<double>{5, 4, 3, 2, 1}), -1.0);
  EXPECT_NEAR(pearson(x, std::vector<double>{1, 3, 2, 5, 4}), 0.8, 1e-15);
  expect_error([&] { (void)pearson(x, std::vector<double>{1, 2}); }, "unequal length");
  expect_error([&] { (void)pearson(x, std::vector<double>(5, 0.1)); }, "constant");
  expect_error([&] { (void)pearson(std::vector<double>{1}, std::vector<double>{1}); }, "at least 2");
  expect_error([&] { (void)pearson(x, std::vector<double>{1, 2, NAN, 4, 5}); }, "y[2] is not a finite");
}

// Mu's comparison: a measured profile = squareness line + straightness shape + noise; the low-frequency part
// correlates better with the simulated components than the raw signal does (Eq. 20 vs Eq. 19).
TEST(WaveletCorrelation, LowFrequencyPartCorrelatesBetter) {
  const std::size_t n = 2048;
  std::vector<double> y1(n), y2(n), x(n);
  const auto e = noise(n, 0.4, 3);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / n;
    y1[i] = 2.0 * t;                       // squareness: linear in the travel
    y2[i] = 0.3 * std::sin(2 * M_PI * t);  // straightness
    x[i] = y1[i] + y2[i] + e[i];
  }
  const auto r = wavelet_correlation(x, {y1, y2}, Wavelet("db1"), Mode::symmetric, 5);
  ASSERT_EQ(r.gamma_x_y.size(), 2u);
  EXPECT_GT(r.gamma_x1_y[0], r.gamma_x_y[0]);
  EXPECT_GT(r.gamma_x1_y[0], 0.9);
  EXPECT_EQ(r.x1.size(), n);
}

TEST(CrossCorrelation, FindsTheDelay) {
  const auto x = noise(1000, 1.0, 1);
  std::vector<double> y(1000, 0.0);
  for (std::size_t i = 0; i + 17 < 1000; ++i) y[i + 17] = x[i];
  const auto r = cross_correlation(x, y, 50);
  EXPECT_EQ(r.peak_lag, 17);
  EXPECT_GT(r.peak_value, 0.95);
  EXPECT_EQ(r.values.size(), 101u);
  EXPECT_NEAR(r.values[50], pearson(x, y), 1e-12);
  const auto clamped = cross_correlation(std::vector<double>{1, 2, 4}, std::vector<double>{1, 3, 2}, 100);
  EXPECT_EQ(clamped.max_lag, 2);
}

TEST(SlidingCorrelation, MatchesPearsonOverTheWindow) {
  const std::size_t w = 64;
  const auto x = noise(1000, 1.0, 7);
  auto y = noise(1000, 1.0, 8);
  for (std::size_t i = 0; i < y.size(); ++i) y[i] = 0.7 * x[i] + 0.3 * y[i] + 1e6;  // large offset
  SlidingCorrelation s(w);
  EXPECT_FALSE(s.ready());
  expect_error([&] { (void)s.value(); }, "fewer than 2");
  for (std::size_t i = 0; i < x.size(); ++i) {
    s.push(x[i], y[i]);
    if (i + 1 >= w && i % 37 == 0) {
      const std::span<const double> xs(x.data() + i + 1 - w, w), ys(y.data() + i + 1 - w, w);
      ASSERT_NEAR(s.value(), pearson(xs, ys), 1e-9) << i;
    }
  }
  SlidingCorrelation c(8);
  for (int i = 0; i < 20; ++i) c.push(1.0, static_cast<double>(i));
  EXPECT_FALSE(c.ready());
  expect_error([&] { (void)c.value(); }, "x is constant");
  expect_error([&] { c.push(NAN, 1.0); }, "not a finite");
}

}  // namespace
}  // namespace guideway::dsp
