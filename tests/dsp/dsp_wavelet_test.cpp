// Wavelet filter banks and batch transforms: properties that hold independently of PyWavelets (the values are
// compared with PyWavelets in dsp_reference_test.py), argument errors, denoising behaviour.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dsp/denoise.hpp"
#include "dsp/detail/kernels.hpp"
#include "dsp/wavelet.hpp"

namespace guideway::dsp {
namespace {

TEST(WaveletFilters, AreOrthonormalQuadratureMirrorFilters) {
  for (const auto& name : Wavelet::names()) {
    const Wavelet w(name);
    const std::size_t F = w.filter_length();
    ASSERT_EQ(F % 2, 0u) << name;
    double sum = 0.0;
    double energy = 0.0;
    for (std::size_t j = 0; j < F; ++j) {
      sum += w.dec_lo()[j];
      energy += w.dec_lo()[j] * w.dec_lo()[j];
      EXPECT_EQ(w.rec_lo()[j], w.dec_lo()[F - 1 - j]) << name;
      EXPECT_EQ(w.rec_hi()[j], w.dec_hi()[F - 1 - j]) << name;
    }
    // PyWavelets' published tables (which we reproduce bit for bit) are orthonormal to ~5e-12 for some
    // symlets (sym20: 1.4e-11), to ~1e-15 for the Daubechies filters.
    const double tol = name.rfind("db", 0) == 0 ? 1e-14 : 3e-11;
    EXPECT_NEAR(sum, std::sqrt(2.0), tol) << name;
    EXPECT_NEAR(energy, 1.0, tol) << name;
    // Orthogonality to even shifts.
    for (std::size_t s = 2; s < F; s += 2) {
      double dot = 0.0;
      for (std::size_t j = 0; j + s < F; ++j) dot += w.dec_lo()[j] * w.dec_lo()[j + s];
      EXPECT_NEAR(dot, 0.0, tol) << name << " shift " << s;
    }
  }
  EXPECT_EQ(Wavelet::names().size(), 20u + 19u + 5u);
  EXPECT_EQ(Wavelet("haar").name(), "db1");
}

TEST(WaveletFilters, UnknownNamesAndModesSayWhat) {
  try {
    (void)Wavelet("db99");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("db99"), std::string::npos);
  }
  EXPECT_THROW((void)parse_mode("smooth"), std::invalid_argument);
  for (const auto& m : mode_names()) EXPECT_EQ(mode_name(parse_mode(m)), m);
}

// The AVX2 and baseline kernels must give the same bits (no fused multiply-add, same order per output).
TEST(WaveletKernels, VariantsAgreeBitForBit) {
  std::mt19937_64 rng(9);
  std::normal_distribution<double> g;
  std::vector<double> x(700), y1(700), y2(700), a1(300), a2(300), d1(300), d2(300);
  for (auto& v : x) v = g(rng);
  for (std::size_t F = 2; F <= 40; F += 2) {
    const auto& base = detail::kernels_variant(F, false);
    const auto& fast = detail::kernels_variant(F, true);
    const Wavelet w(F == 2 ? "db1" : "db" + std::to_string(F / 2));
    for (std::size_t n : {1u, 7u, 8u, 64u, 65u, 200u}) {
      base.analysis(x.data(), n, w.dec_lo().data(), w.dec_hi().data(), a1.data(), d1.data());
      fast.analysis(x.data(), n, w.dec_lo().data(), w.dec_hi().data(), a2.data(), d2.data());
      for (std::size_t i = 0; i < n; ++i) ASSERT_TRUE(a1[i] == a2[i] && d1[i] == d2[i]) << F << " " << n << " " << i;
      base.synthesis2(x.data(), x.data() + 300, n, w.rec_lo().data(), w.rec_hi().data(), y1.data());
      fast.synthesis2(x.data(), x.data() + 300, n, w.rec_lo().data(), w.rec_hi().data(), y2.data());
      for (std::size_t i = 0; i < 2 * n; ++i) ASSERT_EQ(y1[i], y2[i]) << F << " " << n << " " << i;
      base.synthesis1(x.data(), n, w.rec_hi().data(), y1.data());
      fast.synthesis1(x.data(), n, w.rec_hi().data(), y2.data());
      for (std::size_t i = 0; i < 2 * n; ++i) ASSERT_EQ(y1[i], y2[i]) << F << " " << n << " " << i;
    }
  }
}

TEST(WaveletLengths, FollowPyWavelets) {
  EXPECT_EQ(dwt_coeff_len(10, 8, Mode::symmetric), 8u);
  EXPECT_EQ(dwt_coeff_len(11, 8, Mode::periodization), 6u);
  EXPECT_EQ(dwt_max_level(13, 8), 0);
  EXPECT_EQ(dwt_max_level(14, 8), 1);
  EXPECT_EQ(dwt_max_level(1000, 2), 9);
  EXPECT_EQ(idwt_len(8, 8, Mode::zero), 10u);
}

TEST(Wavelet, PerfectReconstructionInEveryMode) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> g;
  for (std::size_t n : {1u, 2u, 3u, 31u, 256u, 1001u}) {
    std::vector<double> x(n);
    for (auto& v : x) v = g(rng);
    for (const auto& mname : mode_names()) {
      const Mode mode = parse_mode(mname);
      for (const char* wn : {"db1", "db3", "db10", "sym7", "coif4"}) {
        const Wavelet w(wn);
        const auto c = wavedec(x, w, mode);
        const auto y = waverec(c, w, mode);
        ASSERT_GE(y.size(), n);
        for (std::size_t i = 0; i < n; ++i) ASSERT_NEAR(y[i], x[i], 1e-11) << wn << " " << mname << " n=" << n;
        const auto comps = mra(x, w, mode, std::max(1, dwt_max_level(n, w.filter_length())));
        for (std::size_t i = 0; i < n; ++i) {
          double s = 0.0;
          for (const auto& comp : comps) s += comp[i];
          ASSERT_NEAR(s, x[i], 1e-11);
        }
      }
    }
  }
}

TEST(Wavelet, PlanReusesBuffersAndChecksSizes) {
  const Wavelet w("db4");
  WaveletPlan plan(w, Mode::periodization, 1000, 5);
  EXPECT_EQ(plan.band_count(), 6u);
  EXPECT_EQ(plan.band_length(0), 32u);
  EXPECT_EQ(plan.band_length(5), 500u);
  std::vector<double> x(1000, 1.0), packed(plan.coeff_count()), out(plan.reconstruction_length());
  plan.decompose(x, packed);
  plan.reconstruct(packed, out);
  for (double v : out) EXPECT_NEAR(v, 1.0, 1e-12);
  EXPECT_THROW(plan.decompose(std::vector<double>(999), packed), std::invalid_argument);
  EXPECT_THROW(plan.reconstruct(std::vector<double>(3), out), std::invalid_argument);
  EXPECT_THROW(WaveletPlan(w, Mode::zero, 0, 1), std::invalid_argument);
}

TEST(Wavelet, ErrorsNameTheProblem) {
  const Wavelet w("db2");
  EXPECT_THROW((void)dwt({}, w, Mode::zero), std::invalid_argument);
  EXPECT_THROW((void)idwt(std::vector<double>(3), std::vector<double>(4), w, Mode::zero), std::invalid_argument);
  Coefficients bad{std::vector<double>(5), std::vector<double>(3)};
  try {
    (void)waverec(bad, w, Mode::zero);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("mismatch"), std::string::npos);
  }
}

TEST(Denoise, UniversalThresholdRemovesMostOfTheNoise) {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> g(0.0, 0.2);
  const std::size_t n = 4096;
  std::vector<double> clean(n), noisy(n);
  for (std::size_t i = 0; i < n; ++i) {
    clean[i] = std::sin(2 * M_PI * 4.0 * static_cast<double>(i) / n) + (i > n / 2 ? 0.5 : 0.0);
    noisy[i] = clean[i] + g(rng);
  }
  auto rms = [&](const std::vector<double>& y) {
    double s = 0.0;
    for (std::size_t i = 0; i < n; ++i) s += (y[i] - clean[i]) * (y[i] - clean[i]);
    return std::sqrt(s / n);
  };
  for (auto rule : {ThresholdRule::soft, ThresholdRule::hard}) {
    for (bool ld : {false, true}) {
      DenoiseOptions o;
      o.rule = rule;
      o.level_dependent = ld;
      const auto r = denoise(noisy, Wavelet("sym8"), Mode::symmetric, 6, o);
      ASSERT_EQ(r.signal.size(), n);
      EXPECT_NEAR(r.sigma, 0.2, 0.02);
      EXPECT_LT(rms(r.signal), 0.5 * rms(noisy));
      EXPECT_EQ(r.thresholds[0], 0.0);
    }
  }
  EXPECT_DOUBLE_EQ(apply_threshold(-3.0, 1.0, ThresholdRule::soft), -2.0);
  EXPECT_DOUBLE_EQ(apply_threshold(0.5, 1.0, ThresholdRule::hard), 0.0);
  EXPECT_DOUBLE_EQ(apply_threshold(1.0, 1.0, ThresholdRule::hard), 1.0);
  std::vector<double> with_nan(noisy);
  with_nan[7] = std::nan("");
  EXPECT_THROW((void)denoise(with_nan, Wavelet("db4"), Mode::zero, 3), std::invalid_argument);
}

}  // namespace
}  // namespace guideway::dsp
