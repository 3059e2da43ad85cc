// Distribution functions and whiteness tests of models/explain against scipy 1.10 (values computed
// with /usr/bin/python3: scipy.special.betainc/gammaincc, scipy.stats.f/chi2/norm, and the textbook
// runs-test and Ljung-Box formulas in numpy on the same deterministic series).
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "models/explain/stats.hpp"

using namespace guideway;

TEST(ExplainStats, IncompleteBetaAndGammaMatchScipy) {
  EXPECT_NEAR(models::explain::incomplete_beta(2.5, 3.5, 0.3), 0.2967529892956661, 1e-13);
  EXPECT_NEAR(models::explain::incomplete_beta(0.5, 40, 0.01), 0.6286139767460155, 1e-13);
  EXPECT_NEAR(models::explain::incomplete_gamma_q(3.0, 2.0), 0.6766764161830634, 1e-13);
  EXPECT_NEAR(models::explain::incomplete_gamma_q(50.5, 60.0), 0.09554063007025347, 1e-12);
}

TEST(ExplainStats, FAndChiSquareSurvivalMatchScipy) {
  EXPECT_NEAR(models::explain::f_sf(3.2, 2, 500), 0.04159841963650194, 1e-12);
  EXPECT_NEAR(models::explain::f_sf(1.1, 10, 7000), 0.35770148914352523, 1e-10);  // lgamma(3505) limits it
  EXPECT_NEAR(models::explain::f_sf(40, 2, 7000) / 5.330134102421666e-18, 1.0, 1e-8);
  EXPECT_NEAR(models::explain::chi2_sf(130.0, 100), 0.02351239780980871, 1e-12);
  EXPECT_NEAR(models::explain::chi2_sf(2.0, 1), 0.15729920705028105, 1e-12);
  EXPECT_NEAR(models::explain::chi2_sf(5000, 4000) / 1.6633156038804178e-25, 1.0, 1e-8);
  EXPECT_EQ(models::explain::chi2_sf(0.0, 3), 1.0);
  EXPECT_THROW((void)models::explain::chi2_sf(1.0, 0), std::invalid_argument);
  EXPECT_THROW((void)models::explain::incomplete_beta(1, 1, 1.5), std::invalid_argument);
}

TEST(ExplainStats, RunsTestAndLjungBoxMatchNumpyFormulas) {
  std::vector<double> x;
  for (int i = 1; i <= 200; ++i) {  // no exact zero (conventions for zeros differ)
    const double t = i;
    x.push_back(std::sin(0.37 * t) + 0.8 * std::sin(2.3 * t * t / 200.0));
  }
  const auto r = models::explain::runs_test(x);
  EXPECT_NEAR(r.statistic, -6.935592031316483, 1e-10);
  EXPECT_NEAR(r.p_value / 4.045234443132569e-12, 1.0, 1e-6);
  const auto q = models::explain::ljung_box(x, 10);
  EXPECT_NEAR(q.statistic, 368.93913265915825, 1e-8);
  EXPECT_NEAR(q.p_value / 3.7917608723488035e-73, 1.0, 1e-6);
  EXPECT_THROW((void)models::explain::ljung_box(x, 0), std::invalid_argument);
  EXPECT_THROW((void)models::explain::ljung_box(x, 200), std::invalid_argument);
}
