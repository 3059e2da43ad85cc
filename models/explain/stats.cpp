// Distribution functions and whiteness tests (stats.hpp): F and chi-square tails, runs and portmanteau tests.
#include "models/explain/stats.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace guideway::models::explain {

namespace {

// Continued fraction of the incomplete beta function (modified Lentz).
double beta_cf(double a, double b, double x) {
  constexpr double tiny = 1e-300, eps = 1e-15;
  const double qab = a + b, qap = a + 1, qam = a - 1;
  double c = 1, d = 1 - qab * x / qap;
  if (std::abs(d) < tiny) d = tiny;
  d = 1 / d;
  double h = d;
  for (int m = 1; m <= 10000; ++m) {
    const double m2 = 2.0 * m;
    double aa = m * (b - m) * x / ((qam + m2) * (a + m2));
    d = 1 + aa * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1 + aa / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    h *= d * c;
    aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
    d = 1 + aa * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1 + aa / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < eps) break;
  }
  return h;
}

}  // namespace

double incomplete_beta(double a, double b, double x) {
  if (!(a > 0) || !(b > 0) || !(x >= 0 && x <= 1)) throw std::invalid_argument("incomplete_beta: bad argument");
  if (x == 0 || x == 1) return x;
  const double lbt = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  const double bt = std::exp(lbt);
  if (x < (a + 1) / (a + b + 2)) return bt * beta_cf(a, b, x) / a;
  return 1 - bt * beta_cf(b, a, 1 - x) / b;
}

double incomplete_gamma_q(double a, double x) {
  if (!(a > 0) || !(x >= 0)) throw std::invalid_argument("incomplete_gamma_q: bad argument");
  if (x == 0) return 1.0;
  const double lg = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1) {  // series for P
    double sum = 1 / a, del = sum, ap = a;
    for (int n = 0; n < 100000; ++n) {
      ap += 1;
      del *= x / ap;
      sum += del;
      if (std::abs(del) < std::abs(sum) * 1e-16) break;
    }
    return 1 - sum * std::exp(lg);
  }
  constexpr double tiny = 1e-300;  // continued fraction for Q
  double b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    const double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-16) break;
  }
  return std::exp(lg) * h;
}

double f_sf(double f, double d1, double d2) {
  if (!(d1 > 0) || !(d2 > 0)) throw std::invalid_argument("f_sf: degrees of freedom must be positive");
  if (!(f > 0)) return 1.0;
  return incomplete_beta(d2 / 2, d1 / 2, d2 / (d2 + d1 * f));
}

double chi2_sf(double x, double k) {
  if (!(k > 0)) throw std::invalid_argument("chi2_sf: degrees of freedom must be positive");
  if (!(x > 0)) return 1.0;
  return incomplete_gamma_q(k / 2, x / 2);
}

double normal_two_sided(double z) { return std::erfc(std::abs(z) / std::sqrt(2.0)); }

TestResult runs_test(std::span<const double> x) {
  double n1 = 0, n2 = 0, runs = 0;
  int last = 0;
  for (double v : x) {
    const int s = v > 0 ? 1 : (v < 0 ? -1 : 0);
    if (s == 0) continue;
    (s > 0 ? n1 : n2) += 1;
    if (s != last) runs += 1;
    last = s;
  }
  TestResult r;
  const double n = n1 + n2;
  if (n1 < 1 || n2 < 1) {  // all one sign: as structured as it gets when long enough
    r.statistic = -std::sqrt(n);
    r.p_value = n > 1 ? std::pow(0.5, n - 1) : 1.0;
    return r;
  }
  const double mean = 2 * n1 * n2 / n + 1;
  const double var = 2 * n1 * n2 * (2 * n1 * n2 - n) / (n * n * (n - 1));
  r.statistic = var > 0 ? (runs - mean) / std::sqrt(var) : 0.0;
  r.p_value = normal_two_sided(r.statistic);
  return r;
}

TestResult ljung_box(std::span<const double> x, std::size_t lags) {
  const std::size_t n = x.size();
  if (lags == 0 || lags >= n) throw std::invalid_argument("ljung_box: need 0 < lags < n");
  double mean = 0;
  for (double v : x) mean += v;
  mean /= static_cast<double>(n);
  double c0 = 0;
  for (double v : x) c0 += (v - mean) * (v - mean);
  TestResult r;
  r.dof = static_cast<double>(lags);
  if (!(c0 > 0)) return r;
  double q = 0;
  for (std::size_t k = 1; k <= lags; ++k) {
    double ck = 0;
    for (std::size_t i = k; i < n; ++i) ck += (x[i] - mean) * (x[i - k] - mean);
    const double rho = ck / c0;
    q += rho * rho / static_cast<double>(n - k);
  }
  r.statistic = static_cast<double>(n) * static_cast<double>(n + 2) * q;
  r.p_value = chi2_sf(r.statistic, r.dof);
  return r;
}

}  // namespace guideway::models::explain
