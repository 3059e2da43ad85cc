#pragma once
// Distribution functions and whiteness tests used to decide whether a residual is noise: F and
// chi-square survival functions (regularised incomplete beta and gamma functions), the Wald-Wolfowitz
// runs test and the Ljung-Box portmanteau test. Checked against scipy (tests/models/explain/explain_stats_test.cpp).
// Pure functions; thread safe; throw std::invalid_argument on meaningless arguments.

#include <cstddef>
#include <span>

namespace guideway::models::explain {

// Regularised incomplete beta I_x(a, b), a, b > 0, 0 <= x <= 1.
double incomplete_beta(double a, double b, double x);
// Regularised upper incomplete gamma Q(a, x), a > 0, x >= 0.
double incomplete_gamma_q(double a, double x);

// P(F > f) for F(d1, d2).
double f_sf(double f, double d1, double d2);
// P(X > x) for chi-square with k degrees of freedom.
double chi2_sf(double x, double k);
// P(|Z| > |z|) for a standard normal Z.
double normal_two_sided(double z);

struct TestResult {
  double statistic = 0.0;
  double p_value = 1.0;
  double dof = 0.0;
};

// Runs test on the signs of x about zero (zeros skipped): z of the number of runs, two-sided p.
TestResult runs_test(std::span<const double> x);
// Ljung-Box Q over lags 1..lags (mean removed), chi-square with `lags` degrees of freedom.
TestResult ljung_box(std::span<const double> x, std::size_t lags);

}  // namespace guideway::models::explain
