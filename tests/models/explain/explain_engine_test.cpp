// The EXPLAIN engine on synthetic problems with a known answer: a base (offset + first harmonic), a
// step effect and a sinusoid as candidates, white noise. Checks the selection, the parameter against
// the truth, the held-out improvement, the null case and an out-of-library bump.
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/QR>
#include <nlohmann/json.hpp>

#include "models/explain/engine/explain_pass.hpp"
#include "models/explain/engine/level_step.hpp"
#include "models/explain/engine/set_aside.hpp"
#include "models/explain/explain.hpp"
#include "models/explain/explanation.hpp"
#include "sanitizer_build.hpp"

using namespace guideway;

namespace {

constexpr double pi = std::numbers::pi;
constexpr int n = 2000;
// Under a sanitizer the statistical cases below run a few draws for their code paths and judge no rates:
// the rates over all the draws are judged in the Release build (a sanitizer sees nothing more in draw 40).
#if defined(GUIDEWAY_SANITIZED_ADDRESS) || defined(GUIDEWAY_SANITIZED_THREAD)
constexpr bool judge_rates = false;
#else
constexpr bool judge_rates = true;
#endif

double step_of(int i) { return (i % 500) < 250 ? 0.5 : -0.5; }

// N(0, 1) by Box-Muller from the raw 64-bit draws: the same numbers with every standard library
// (std::normal_distribution's algorithm is implementation-defined, and the counts below depend on them).
double gauss(std::mt19937_64& rng) {
  const double u1 = (static_cast<double>(rng() >> 11) + 0.5) * 0x1p-53;  // (0, 1)
  const double u2 = static_cast<double>(rng() >> 11) * 0x1p-53;          // [0, 1)
  return std::sqrt(-2 * std::log(u1)) * std::cos(2 * pi * u2);
}

// y = 3 + 2 cos + 1 sin + extra(i) + N(0, 0.4^2).
models::explain::Problem make_problem(const std::function<double(int)>& extra, unsigned seed) {
  models::explain::Problem p;
  p.model = "synthetic";
  p.domain = "angle_deg";
  p.runs.push_back({"run1", 1, 1000, "g", "", 0.0});
  std::mt19937_64 rng(seed);
  p.base.names = {"offset_um", "cos_um", "sin_um"};
  p.base.columns.resize(n, 3);
  models::explain::Candidate step{"backlash", "a step", {}, {}, 0};
  models::explain::Candidate sine{"vibration", "a sinusoid", {}, {}, 0};
  step.variants.resize(1);
  step.variants[0].block.names = {"step_um"};
  step.variants[0].block.columns.resize(n, 1);
  sine.variants.resize(1);
  sine.variants[0].block.names = {"vib_sin_um", "vib_cos_um"};
  sine.variants[0].block.columns.resize(n, 2);
  for (int i = 0; i < n; ++i) {
    const double z = 2 * pi * i / n;
    p.base.columns.row(i) << 1.0, std::cos(z), std::sin(z);
    step.variants[0].block.columns(i, 0) = step_of(i);
    sine.variants[0].block.columns.row(i) << std::sin(37 * z), std::cos(37 * z);
    const double y = 3 + 2 * std::cos(z) + std::sin(z) + extra(i) + 0.4 * gauss(rng);
    p.samples.push_back({0, y, z * 180 / pi, i * 0.01});
  }
  p.candidates = {sine, step};
  return p;
}

}  // namespace

TEST(ExplainEngine, FindsTheStepWithItsSizeAndImprovesHeldOut) {
  const auto rep = models::explain::explain(make_problem([](int i) { return 0.3 * step_of(i) / 0.5 * 0.5; }, 1));
  ASSERT_EQ(rep.findings.size(), 1u);
  EXPECT_EQ(rep.findings[0].effect, "backlash");
  ASSERT_EQ(rep.findings[0].parameters.size(), 1u);
  const auto& par = rep.findings[0].parameters[0];
  EXPECT_EQ(par.name, "step_um");
  EXPECT_NEAR(par.value, 0.3, 4 * par.u);
  EXPECT_LT(par.u, 0.02);
  EXPECT_LT(rep.final_fit.heldout_rms_um, rep.baseline.heldout_rms_um);
  EXPECT_LT(rep.findings[0].delta_bic, 0);
  EXPECT_LT(rep.findings[0].p_value, 1e-3);
  EXPECT_FALSE(rep.unexplained);
  EXPECT_FALSE(rep.mismatch.empty());
  EXPECT_NEAR(rep.noise_um, 0.4, 0.04);
  // Its size: the fitted term's peak-to-valley, the step column spanning 1 (+-0.5) times its coefficient;
  // no yardstick in this problem, so no percentage.
  EXPECT_NEAR(rep.findings[0].contribution_um, std::abs(par.value), 1e-12);
  EXPECT_TRUE(std::isnan(rep.findings[0].contribution_percent));
  const auto j = results::to_json(models::explain::explanation_of(rep));
  for (const char* key : {"model", "baseline", "mismatch", "findings", "final", "unexplained"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_TRUE(j["findings"][0]["parameters"]["step_um"].contains("u"));
  EXPECT_NE(models::explain::to_text(rep).find("backlash"), std::string::npos);
  // Residual curves for plots: one grid, then per step (base model, + each finding) one curve per run,
  // each step whiter than the one before.
  const auto& res = j["residuals"];
  ASSERT_EQ(res["steps"].size(), 2u);
  EXPECT_EQ(res["steps"][0]["label"], "base model");
  EXPECT_EQ(res["steps"][1]["label"], "+ backlash");
  EXPECT_EQ(res["domain"], "angle_deg");
  EXPECT_LE(res["x"].size(), 720u);
  double base2 = 0, fin2 = 0;
  for (const auto& step : res["steps"]) ASSERT_EQ(step["residual_um"].size(), res["runs"].size());
  for (std::size_t r = 0; r < res["runs"].size(); ++r) {
    const auto& base = res["steps"][0]["residual_um"][r];
    const auto& fin = res["steps"][1]["residual_um"][r];
    ASSERT_EQ(base.size(), res["x"].size());
    ASSERT_EQ(fin.size(), res["x"].size());
    for (std::size_t i = 0; i < base.size(); ++i) {
      if (base[i].is_number()) base2 += std::pow(base[i].get<double>(), 2);
      if (fin[i].is_number()) fin2 += std::pow(fin[i].get<double>(), 2);
    }
  }
  EXPECT_LT(fin2, base2);
}

TEST(ExplainEngine, NoiseOnlyGivesNoFinding) {
  for (unsigned seed : {2u, 3u, 4u}) {
    const auto rep = models::explain::explain(make_problem([](int) { return 0.0; }, seed));
    EXPECT_TRUE(rep.findings.empty()) << seed;
    EXPECT_FALSE(rep.unexplained) << seed;
    EXPECT_TRUE(rep.mismatch.empty()) << seed;
  }
}

// A variant's rank against the model: two columns well apart add two (their joint fit as a plain least
// squares gives it), two 1e-3 apart still two, and two whose difference is 1e-12 to 3e-10 of their size one,
// as one column would (the rank test, rank_tolerance 1e-9). The engine decides the first by the Gram matrix
// of the columns and the others by a pivoted QR: the Gram matrix could not resolve 1e-9.
TEST(ExplainEngine, NearlyCollinearColumnsAddTheRankAPivotedQrGives) {
  const auto candidate = [](const std::string& effect, double apart, int columns) {
    models::explain::Candidate c{effect, "columns", {}, {}, 0};
    c.variants.resize(1);
    c.variants[0].block.columns.resize(n, columns);
    for (int k = 0; k < columns; ++k) c.variants[0].block.names.push_back(effect + std::to_string(k));
    for (int i = 0; i < n; ++i) {
      const double z = 2 * pi * i / n;
      c.variants[0].block.columns(i, 0) = std::sin(11 * z);
      if (columns > 1) c.variants[0].block.columns(i, 1) = std::sin(11 * z) + apart * std::sin(23 * z);
    }
    return c;
  };
  const auto delta_bics = [](const models::explain::Problem& p) {
    const auto rep = models::explain::explain(p);
    EXPECT_TRUE(rep.findings.empty());
    std::map<std::string, double> out;
    for (const auto& c : rep.considered) out[c.effect] = c.delta_bic;
    return out;
  };
  models::explain::Problem p = make_problem([](int) { return 0.0; }, 5);
  p.candidates = {candidate("thermal_drift", 1e-3, 2), candidate("vibration", 1, 2)};
  auto apart = delta_bics(p);
  // The joint fit of the base and the two columns apart, independently: n ln(RSS/n) + rank ln n.
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) y[i] = p.samples[static_cast<std::size_t>(i)].y_um;
  const auto bic = [&](const Eigen::MatrixXd& j) {
    const Eigen::VectorXd r = y - j * j.colPivHouseholderQr().solve(y);
    return n * std::log(r.squaredNorm() / n) + static_cast<double>(j.cols()) * std::log(static_cast<double>(n));
  };
  Eigen::MatrixXd joint(n, 5);
  joint << p.base.columns, p.candidates[1].variants[0].block.columns;
  const double expected = bic(joint) - bic(p.base.columns);
  EXPECT_NEAR(apart["vibration"], expected, 1e-6);
  EXPECT_NEAR(apart["thermal_drift"], expected, 1e-6);  // the same span
  for (const double d : {1e-12, 3e-12, 1e-11, 3e-11, 1e-10, 3e-10}) {
    p.candidates = {candidate("backlash", 0, 1), candidate("cyclic_error", d, 2)};
    auto collinear = delta_bics(p);
    EXPECT_NEAR(collinear["cyclic_error"], collinear["backlash"], 1e-6) << d;
    EXPECT_LT(collinear["cyclic_error"], expected - 0.5 * std::log(static_cast<double>(n))) << d;  // a rank less
  }
}

// Noise that is not white (a moving average with a negative weight: the runs test and Ljung-Box reject it),
// with nothing above the noise anywhere: no place, no effect. Not `unexplained` (a verdict without a place),
// but a note that says what the tests saw (docs/explain.md step 5).
TEST(ExplainEngine, CorrelatedNoiseWithNoPlaceIsANoteNotUnexplained) {
  std::mt19937_64 rng(11);
  std::vector<double> g(n + 1);
  for (double& v : g) v = gauss(rng);
  const auto rep = models::explain::explain(make_problem([&g](int i) { return 0.4 * (g[i + 1] - 0.6 * g[i]); }, 12));
  EXPECT_TRUE(rep.findings.empty());
  EXPECT_FALSE(rep.unexplained);
  EXPECT_TRUE(rep.remaining.empty());
  const bool noted = std::any_of(rep.notes.begin(), rep.notes.end(), [](const std::string& s) {
    return s.find("not white noise") != std::string::npos && s.find("Ljung-Box") != std::string::npos;
  });
  EXPECT_TRUE(noted) << "the residual was white or located: the test no longer reaches its case";
  // White noise: no such note.
  const auto white = models::explain::explain(make_problem([](int) { return 0.0; }, 12));
  EXPECT_TRUE(std::none_of(white.notes.begin(), white.notes.end(),
                           [](const std::string& s) { return s.find("not white noise") != std::string::npos; }));
}

TEST(ExplainEngine, BumpOutsideTheLibraryIsLocatedNotAttributed) {
  // A 2 um Gaussian bump at sample 700 (126 deg), 15 samples wide.
  const auto rep = models::explain::explain(make_problem(
      [](int i) {
        const double d = (i - 700) / 15.0;
        return 2.0 * std::exp(-0.5 * d * d);
      },
      5));
  EXPECT_TRUE(rep.findings.empty());
  EXPECT_TRUE(rep.unexplained);
  ASSERT_FALSE(rep.mismatch.empty());
  bool located = false;
  for (const auto& [lo, hi] : rep.mismatch[0].ranges) located |= lo <= 127 && 125 <= hi;
  EXPECT_TRUE(located) << rep.mismatch[0].where;
}

// The problem of the samples a set-aside pass keeps is as untimed as the whole (a traverse read without t_s): the
// places that pass locates then speak of readings, never of seconds.
TEST(ExplainEngine, TheSamplesKeptAreAsUntimedAsTheWhole) {
  models::explain::Problem p = make_problem([](int) { return 0.0; }, 5);
  std::vector<bool> keep(n, true);
  std::fill(keep.begin() + 690, keep.begin() + 710, false);
  for (const bool timed : {false, true}) {
    p.timed = timed;
    const auto reduced = models::explain::engine::without_samples(p, keep, {{0, 710}});
    EXPECT_EQ(reduced.problem.timed, timed);
    EXPECT_EQ(reduced.problem.samples.size(), static_cast<std::size_t>(n - 20));
  }
}

TEST(ExplainEngine, RejectsUnusableProblems) {
  auto p = make_problem([](int) { return 0.0; }, 6);
  auto few = p;
  few.samples.resize(10);
  EXPECT_THROW((void)models::explain::explain(few), std::invalid_argument);
  auto rows = p;
  rows.candidates[0].variants[0].block.columns.conservativeResize(n - 1, Eigen::NoChange);
  EXPECT_THROW((void)models::explain::explain(rows), std::invalid_argument);
  auto nanp = p;
  nanp.samples[5].y_um = std::nan("");
  EXPECT_THROW((void)models::explain::explain(nanp), std::invalid_argument);
}

TEST(ExplainEngine, HoldsOutWholeRunsWhenThereAreThree) {
  auto p = make_problem([](int i) { return 0.3 * step_of(i); }, 7);
  p.runs = {{"a", 1, 1000, "g", "", 0.0}, {"b", 1, 1000, "g", "", 0.0}, {"c", 1, 1000, "g", "", 0.0}};
  for (int i = 0; i < n; ++i)
    p.samples[static_cast<std::size_t>(i)].run = static_cast<std::size_t>(std::min(i * 3 / n, 2));
  const auto rep = models::explain::explain(p);
  EXPECT_EQ(rep.heldout_scheme.rfind("leave-one-run-out", 0), 0u) << rep.heldout_scheme;
  ASSERT_FALSE(rep.findings.empty());
  EXPECT_EQ(rep.findings[0].effect, "backlash");
  EXPECT_LT(rep.final_fit.heldout_rms_um, rep.baseline.heldout_rms_um);
  // Runs must be contiguous.
  p.samples[10].run = 2;
  EXPECT_THROW((void)models::explain::explain(p), std::invalid_argument);
}

namespace {

// Pure noise (or noise + a sinusoid) and one candidate whose variant is generated from the residual: the
// sinusoid at the periodogram's highest peak with its phase, over 0.25-cycle steps up to Nyquist -- ~500
// frequencies searched but declared as one (search_size 1), so that neither the Bonferroni factor nor the
// share rule stands between noise and a finding: only the held-out test does.
models::explain::Problem peak_problem(double amplitude, unsigned seed) {
  constexpr int m = 256;
  models::explain::Problem p;
  p.model = "synthetic";
  p.domain = "angle_deg";
  p.runs.push_back({"run1", 1, 1000, "g", "", 0.0});
  std::mt19937_64 rng(seed);
  p.base.names = {"offset_um"};
  p.base.columns = Eigen::MatrixXd::Ones(m, 1);
  for (int i = 0; i < m; ++i)
    p.samples.push_back({0, amplitude * std::sin(2 * pi * 17.3 * i / m) + gauss(rng), i * 360.0 / m, i * 0.01});
  models::explain::Candidate peak{"vibration", "the periodogram's highest peak", {}, {}, 1};
  peak.generate = [](const Eigen::VectorXd& r, const std::vector<bool>& use) {
    double best = -1, best_f = 0, best_phase = 0;
    for (double f = 1; f < m / 2; f += 0.25) {
      double c = 0, s = 0;
      for (int i = 0; i < m; ++i)
        if (use[static_cast<std::size_t>(i)]) {
          c += r[i] * std::cos(2 * pi * f * i / m);
          s += r[i] * std::sin(2 * pi * f * i / m);
        }
      if (c * c + s * s > best) {
        best = c * c + s * s;
        best_f = f;
        best_phase = std::atan2(s, c);
      }
    }
    models::explain::Variant v;
    v.block.names = {"peak_um"};
    v.block.columns.resize(m, 1);
    for (int i = 0; i < m; ++i) v.block.columns(i, 0) = std::cos(2 * pi * best_f * i / m - best_phase);
    return std::vector<models::explain::Variant>{v};
  };
  p.candidates = {peak};
  return p;
}

// The held-out RMS after the one trial of a single-round report: the finding's, or the one its verdict
// quotes when the held-out test refused it; NaN when another gate refused it first.
double trial_heldout(const models::explain::Report& r) {
  if (!r.findings.empty()) return r.findings[0].heldout_rms_um_after;
  const std::string lead = "held-out RMS not improved (";
  if (r.considered.size() != 1 || r.considered[0].verdict.rfind(lead, 0) != 0) return std::nan("");
  return std::stod(r.considered[0].verdict.substr(lead.size()));
}

}  // namespace

// The held-out RMS re-chooses generated variants inside each fold (docs/explain.md "Held out"). On pure
// noise, a peak picked on all the data also "predicts" the held-out rows it was picked on: with the
// variant kept fixed the held-out RMS improves by selection alone and noise is taken as a finding; with
// the choice nested in the folds it does not. A real sinusoid is found both ways.
TEST(ExplainEngine, HeldOutRechoosesGeneratedVariantsInEachFold) {
  models::explain::ExplainOptions loose;
  loose.alpha = 1.0;      // no significance gate (p <= 1 passes unless exactly 1)
  loose.min_share = 0.0;  // no share gate
  loose.max_effects = 1;
  models::explain::ExplainOptions fixed = loose;
  fixed.heldout_reselect = false;
  int taken_fixed = 0, taken_nested = 0;
  constexpr int trials = judge_rates ? 40 : 4;
  int compared = 0, higher = 0;  // draws where the nested held-out figure of the trial is above the fixed one
  for (unsigned seed = 1; seed <= trials; ++seed) {
    const auto p = peak_problem(0.0, seed);
    const auto a = models::explain::explain(p, fixed), b = models::explain::explain(p, loose);
    taken_fixed += !a.findings.empty();
    taken_nested += !b.findings.empty();
    // BIC and F-test are the same both ways: only the held-out figure differs, and it is what refused.
    // (The one candidate is either a finding or considered.)
    ASSERT_EQ(a.considered.size() + a.findings.size(), 1u);
    ASSERT_EQ(b.considered.size() + b.findings.size(), 1u);
    if (!a.findings.empty() && b.findings.empty()) {
      EXPECT_EQ(b.considered[0].verdict.rfind("held-out RMS not improved", 0), 0u) << b.considered[0].verdict;
    }
    // The trial's held-out figure: nested above fixed (the fixed one saw the held-out rows in the choice).
    const double ho_fixed = trial_heldout(a), ho_nested = trial_heldout(b);
    if (std::isfinite(ho_fixed) && std::isfinite(ho_nested)) {  // else the BIC refused it first (both ways)
      ++compared;
      higher += ho_nested > ho_fixed;
    }
  }
  if (judge_rates) {
    EXPECT_GE(compared, trials * 3 / 4);
    EXPECT_GE(higher, compared * 9 / 10) << "nested above fixed in " << higher << " of " << compared;
    EXPECT_GE(taken_fixed, trials * 3 / 4) << "fixed variants: noise taken in " << taken_fixed << " of " << trials;
    EXPECT_LE(taken_nested, trials / 5) << "nested: noise taken in " << taken_nested << " of " << trials;
  }
  // (Measured with these draws: 37 of 40 fixed, 1 of 40 nested; the nested figure above the fixed one in
  // 37 of the 37 draws the held-out test judged. A held-out block can favour a spurious term by chance.)
  // A real sinusoid (amplitude 1 x the noise's sigma) improves the held-out RMS both ways; the nested
  // figure is the less flattering one (measured 0.003-0.04 um above the fixed one).
  for (unsigned seed = 1; seed <= (judge_rates ? 5u : 2u); ++seed) {
    const auto p = peak_problem(1.0, seed);
    const auto a = models::explain::explain(p, fixed), b = models::explain::explain(p, loose);
    ASSERT_EQ(a.findings.size(), 1u) << seed;
    ASSERT_EQ(b.findings.size(), 1u) << seed;
    EXPECT_LT(b.final_fit.heldout_rms_um, b.baseline.heldout_rms_um - 0.1) << seed;
    EXPECT_GE(b.final_fit.heldout_rms_um, a.final_fit.heldout_rms_um - 1e-3) << seed;
  }
}

namespace {

// Pure noise with an offset base and three candidates: the generated peak above (with a probe that records
// whether any row held out, use[i] false, carries a nonzero residual, and counts its calls on part of the
// rows), a step and a slope, both with a fixed single variant and planted so that all three are taken.
struct Probe {
  int masked_calls = 0;  // calls with some row held out
  bool leaked = false;   // a held-out row had a nonzero residual
};
models::explain::Problem probe_problem(const std::shared_ptr<Probe>& probe) {
  constexpr int m = 256;
  models::explain::Problem p = peak_problem(2.0, 11);
  models::explain::Candidate step{"backlash", "a step", {}, {}, 0}, slope{"thermal_drift", "a slope", {}, {}, 0};
  step.variants.resize(1);
  step.variants[0].block.names = {"step_um"};
  step.variants[0].block.columns.resize(m, 1);
  slope.variants.resize(1);
  slope.variants[0].block.names = {"slope_um"};
  slope.variants[0].block.columns.resize(m, 1);
  for (int i = 0; i < m; ++i) {
    step.variants[0].block.columns(i, 0) = (i % 64) < 32 ? 0.5 : -0.5;
    slope.variants[0].block.columns(i, 0) = (i - m / 2.0) / m;
    p.samples[static_cast<std::size_t>(i)].y_um +=
        1.5 * step.variants[0].block.columns(i, 0) + 3.0 * slope.variants[0].block.columns(i, 0);
  }
  auto gen = p.candidates[0].generate;
  p.candidates[0].generate = [gen, probe](const Eigen::VectorXd& r, const std::vector<bool>& use) {
    bool masked = false;
    for (std::size_t i = 0; i < use.size(); ++i) {
      masked |= !use[i];
      probe->leaked |= !use[i] && r[static_cast<Eigen::Index>(i)] != 0.0;
    }
    probe->masked_calls += masked;
    return gen(r, use);
  };
  p.candidates.push_back(step);
  p.candidates.push_back(slope);
  return p;
}

}  // namespace

// A generator never sees a held-out row's residual, and each fold re-chooses an effect only when it is
// tried and when a later effect joins the model (its choice is then re-decided): the later trials extend
// each fold's kept terms instead of running the generator again.
TEST(ExplainEngine, GeneratorsSeeNoHeldOutRowAndRunOncePerFold) {
  auto probe = std::make_shared<Probe>();
  const auto p = probe_problem(probe);
  models::explain::ExplainOptions opt;
  opt.min_share = 0.0;  // the step and the slope each leave the others' structure
  const auto rep = models::explain::explain(p, opt);
  ASSERT_EQ(rep.findings.size(), 3u) << models::explain::to_text(rep);
  EXPECT_EQ(rep.findings[0].effect, "vibration") << models::explain::to_text(rep);
  EXPECT_FALSE(probe->leaked);
  // The peak is tried in round 1, once per fold (8), and re-chosen in every fold when each of the two later
  // effects joins (2 x 8); the trials of the later rounds re-use the folds' choice (re-choosing the terms
  // taken for every trial of a round would add 8 per trial).
  EXPECT_EQ(probe->masked_calls, 24);
  // Leave-one-run-out (three runs) holds out whole runs: the probe still sees zeros only.
  auto loro = probe_problem(probe = std::make_shared<Probe>());
  loro.runs = {{"a", 1, 1000, "g", "", 0.0}, {"b", 1, 1000, "g", "", 0.0}, {"c", 1, 1000, "g", "", 0.0}};
  for (std::size_t i = 0; i < loro.samples.size(); ++i)
    loro.samples[i].run = std::min<std::size_t>(i * 3 / loro.samples.size(), 2);
  const models::explain::Report loro_rep = models::explain::explain(loro, opt);
  EXPECT_EQ(loro_rep.heldout_scheme.rfind("leave-one-run-out", 0), 0u) << loro_rep.heldout_scheme;
  EXPECT_GT(probe->masked_calls, 0);
  EXPECT_FALSE(probe->leaked);
}

// Fixed variants (no generator) are re-chosen in each fold too: ~250 sinusoids on a list, declared as one
// search, on pure noise -- kept fixed, the best of them "predicts" the rows it was picked on.
TEST(ExplainEngine, HeldOutRechoosesFixedVariantsInEachFold) {
  constexpr int m = 256;
  models::explain::ExplainOptions loose;
  loose.alpha = 1.0;
  loose.min_share = 0.0;
  loose.max_effects = 1;
  models::explain::ExplainOptions fixed = loose;
  fixed.heldout_reselect = false;
  int taken_fixed = 0, taken_nested = 0;
  constexpr int trials = judge_rates ? 20 : 2;
  for (unsigned seed = 1; seed <= trials; ++seed) {
    models::explain::Problem p = peak_problem(0.0, seed + 100);
    models::explain::Candidate lines{"cyclic_error", "a listed sinusoid", {}, {}, 1};
    for (double f = 1; f < m / 2; f += 0.5) {
      models::explain::Variant v;
      v.block.names = {"s_um", "c_um"};
      v.block.columns.resize(m, 2);
      for (int i = 0; i < m; ++i) v.block.columns.row(i) << std::sin(2 * pi * f * i / m), std::cos(2 * pi * f * i / m);
      lines.variants.push_back(std::move(v));
    }
    p.candidates = {lines};
    taken_fixed += !models::explain::explain(p, fixed).findings.empty();
    taken_nested += !models::explain::explain(p, loose).findings.empty();
  }
  if (judge_rates) {
    EXPECT_GE(taken_fixed, trials / 2) << taken_fixed;
    EXPECT_LE(taken_nested, trials / 5) << taken_nested;
  }
}

// A fold that cannot be fitted is not skipped (the trial and the model so far would be averaged over
// different rows): the held-out figure is NaN and the effect refused, saying which fold.
TEST(ExplainEngine, AFoldThatCannotBeFittedRefusesTheEffect) {
  models::explain::Problem p = peak_problem(3.0, 5);
  auto gen = p.candidates[0].generate;
  p.candidates[0].generate = [gen](const Eigen::VectorXd& r, const std::vector<bool>& use) {
    return use[0] ? gen(r, use) : std::vector<models::explain::Variant>{};  // nothing when the first block is held out
  };
  const auto rep = models::explain::explain(p);
  EXPECT_TRUE(rep.findings.empty());
  ASSERT_EQ(rep.considered.size(), 1u);
  EXPECT_EQ(
      rep.considered[0].verdict,
      "held-out RMS not computable (fold 1 of 8: vibration has no variant that can be fitted on the training rows)");
  EXPECT_FALSE(
      models::explain::explain(peak_problem(3.0, 5)).findings.empty());  // found when every fold has its variant
}

// sensor_nonlinearity's columns from the base refitted to the rows in use: on all rows they are those of
// the base fitted to all samples; with rows held out, the held-out y does not change them.
TEST(ExplainEngine, SensorNonlinearityColumnsSeeNoHeldOutY) {
  const auto p = make_problem([](int i) { return 0.3 * step_of(i); }, 3);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) y[i] = p.samples[static_cast<std::size_t>(i)].y_um;
  const std::vector<double> offset(n, 0.25);
  const auto gen = models::explain::sensor_nonlinearity_generator(p.base, y, offset);
  // All rows: the reading is the base's full fit (+ offset), computed independently here.
  const Eigen::VectorXd x = p.base.columns.colPivHouseholderQr().solve(y);
  std::vector<double> reading(n);
  for (int i = 0; i < n; ++i) reading[static_cast<std::size_t>(i)] = p.base.columns.row(i).dot(x) + 0.25;
  const auto all = gen(Eigen::VectorXd::Zero(n), std::vector<bool>(n, true));
  ASSERT_EQ(all.size(), 1u);
  const auto ref = models::explain::sensor_nonlinearity_variant(reading);
  EXPECT_LT((all[0].block.columns - ref.block.columns).cwiseAbs().maxCoeff(),
            1e-9 * ref.block.columns.cwiseAbs().maxCoeff());
  // Rows 0..249 held out: a large change of their y leaves the columns as they were.
  std::vector<bool> use(n, true);
  for (int i = 0; i < 250; ++i) use[static_cast<std::size_t>(i)] = false;
  Eigen::VectorXd y2 = y;
  y2.head(250).array() += 50.0;
  const auto a = gen(Eigen::VectorXd::Zero(n), use);
  const auto b = models::explain::sensor_nonlinearity_generator(p.base, y2, offset)(Eigen::VectorXd::Zero(n), use);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(a[0].block.columns, b[0].block.columns);
  // ... while on all rows it moves them (the leak the mask removes).
  const auto c = models::explain::sensor_nonlinearity_generator(p.base, y2, offset)(Eigen::VectorXd::Zero(n),
                                                                                    std::vector<bool>(n, true));
  EXPECT_GT((c[0].block.columns - all[0].block.columns).cwiseAbs().maxCoeff(), 1e-3);
}

// What the engine keeps for reuse (ExplainOptions::memory_mb) changes its cost, never its results: with no room
// for its caches (every model, held-out figure and fold model made again when asked for) the report is the same,
// number for number, on a problem with three findings, a generated candidate and its re-choice in every fold.
TEST(ExplainEngine, ACacheWithoutRoomGivesTheSameReport) {
  const auto p = probe_problem(std::make_shared<Probe>());
  models::explain::ExplainOptions opt;
  opt.min_share = 0.0;
  models::explain::ExplainOptions none = opt;
  none.memory_mb = 0;
  const auto a = models::explain::explain(p, opt), b = models::explain::explain(p, none);
  ASSERT_EQ(a.findings.size(), 3u) << models::explain::to_text(a);
  EXPECT_EQ(results::to_json(models::explain::explanation_of(a)).dump(),
            results::to_json(models::explain::explanation_of(b)).dump());
}

// A variant made on demand (Variant::fill: its columns written where the engine uses them, none held) is the
// same variant as its block: the same report, number for number, whether the step is found or refused.
TEST(ExplainEngine, AVariantMadeOnDemandIsItsBlock) {
  for (const double size : {0.3, 0.0}) {
    const auto eager = make_problem([size](int i) { return size * step_of(i); }, 7);
    auto lazy = eager;
    for (auto& c : lazy.candidates)
      for (auto& v : c.variants) {
        v.fill = [columns = v.block.columns](Eigen::Ref<Eigen::MatrixXd> out) { out = columns; };
        v.block.columns.resize(0, 0);
      }
    const auto a = models::explain::explain(eager), b = models::explain::explain(lazy);
    EXPECT_EQ(a.findings.size(), size > 0 ? 1u : 0u) << size;
    EXPECT_EQ(results::to_json(models::explain::explanation_of(a)).dump(),
              results::to_json(models::explain::explanation_of(b)).dump())
        << size;
  }
}

// A candidate none of whose variants can be fitted beside the model (its column is the base's own, twice over) is
// still listed in `considered`, with why: docs/explain.md promises every candidate there.
TEST(ExplainEngine, ACandidateThatCannotBeFittedIsListedWithWhy) {
  auto p = make_problem([](int) { return 0.0; }, 8);
  models::explain::Candidate twin{"thermal_drift", "the base's offset again", {}, {}, 0};
  twin.variants.resize(1);
  twin.variants[0].block.names = {"twin_um"};
  twin.variants[0].block.columns = 2.0 * p.base.columns.leftCols(1);
  p.candidates.push_back(twin);
  const auto rep = models::explain::explain(p);
  EXPECT_TRUE(rep.findings.empty());
  const auto it = std::find_if(rep.considered.begin(), rep.considered.end(),
                               [](const auto& c) { return c.effect == "thermal_drift"; });
  ASSERT_TRUE(it != rep.considered.end()) << models::explain::to_text(rep);
  EXPECT_EQ(it->verdict, "cannot be fitted: every variant lies in what the base fit");
}

namespace {

// A traverse's two passes as the engine sees them: 400 stations forward, then back, the geometry a line common to
// both (the base), a reflector rocking of `rocking_um` (+ forward, - back) as the one candidate, noise 0.05, and
// after the turnaround a settling transient of 3 um decaying over 3 readings: a place no effect explains, set aside
// where the return pass begins.
models::explain::Problem turnaround_problem(double rocking_um, unsigned seed) {
  constexpr int stations = 400;
  models::explain::Problem p;
  p.model = "synthetic";
  p.domain = "position_mm";
  p.runs = {{"forward", 1, 1000, "g", "", 0.0}, {"return", -1, 1000, "g", "", 0.0}};
  std::mt19937_64 rng(seed);
  p.base.names = {"offset_um", "slope_um"};
  p.base.columns.resize(2 * stations, 2);
  models::explain::Candidate rocking{"reflector_rocking", "+r forward, -r back", {}, {}, 0};
  rocking.variants.resize(1);
  rocking.variants[0].block.names = {"reflector_rocking_um"};
  rocking.variants[0].block.columns.resize(2 * stations, 1);
  for (int i = 0; i < 2 * stations; ++i) {
    const bool back = i >= stations;
    const int k = back ? i - stations : i;         // readings into the pass
    const int station = back ? stations - 1 - k : k;
    const double x = station / static_cast<double>(stations);
    p.base.columns.row(i) << 1.0, x;
    rocking.variants[0].block.columns(i, 0) = back ? -1.0 : 1.0;
    const double settling = back ? 3.0 * std::exp(-k / 3.0) : 0.0;
    const double y = 0.5 + 0.2 * x + (back ? -rocking_um : rocking_um) + settling + 0.05 * gauss(rng);
    p.samples.push_back({back ? 1u : 0u, y, static_cast<double>(station), 2.0 * i});
  }
  p.candidates = {rocking};
  return p;
}

}  // namespace

// Issue 41 item 4: the reading's offset after a place set aside where the return pass begins is, with the base's
// constant, the rocking's own column. Fitted, it left the rocking nothing (the candidate vanished from `considered`
// and the rocking was missed); now it is not fitted, a note says why, and the rocking is found with its size.
TEST(ExplainEngine, AnOffsetAfterAPlaceSetAsideNeverTakesACandidatesColumn) {
  const auto rep = models::explain::explain(turnaround_problem(0.3, 9));
  EXPECT_TRUE(rep.unexplained);
  EXPECT_GT(rep.set_aside, 0u);
  ASSERT_EQ(rep.findings.size(), 1u) << models::explain::to_text(rep);
  EXPECT_EQ(rep.findings[0].effect, "reflector_rocking");
  ASSERT_EQ(rep.findings[0].parameters.size(), 1u);
  EXPECT_NEAR(rep.findings[0].parameters[0].value, 0.3, 0.03);
  const auto note = std::find_if(rep.notes.begin(), rep.notes.end(), [](const std::string& s) {
    return s.find("offset after a place set aside") != std::string::npos;
  });
  ASSERT_TRUE(note != rep.notes.end()) << models::explain::to_text(rep);
  EXPECT_NE(note->find("was not fitted"), std::string::npos) << *note;
  EXPECT_NE(note->find("reflector_rocking's own column"), std::string::npos) << *note;
  // Without a rocking the same turnaround gives no finding, and the candidate is listed with its verdict.
  const auto none = models::explain::explain(turnaround_problem(0.0, 9));
  EXPECT_TRUE(none.findings.empty()) << models::explain::to_text(none);
  ASSERT_EQ(none.considered.size(), 1u) << models::explain::to_text(none);
  EXPECT_EQ(none.considered[0].effect, "reflector_rocking");
}

namespace {

// Two passes over 64 stations, forward then back, a rough geometry (a random walk from station to station: no
// polynomial), a rocking of 0.3 um and a drift in time as the candidates, noise 0.05: the geometry as a term per
// station, given as 64 columns (as columns the engine factors them per fold: 200 took 38 s under ASan).
models::explain::Problem per_station_problem(unsigned seed) {
  constexpr int stations = 64;
  models::explain::Problem p;
  p.model = "synthetic";
  p.domain = "position_mm";
  p.timed = true;
  p.runs = {{"forward", 1, 1000, "g", "", 0.0}, {"return", -1, 1000, "g", "", 0.0}};
  std::mt19937_64 rng(seed);
  std::vector<double> geometry(stations);
  double walk = 0;
  for (double& g : geometry) g = walk += 0.2 * gauss(rng);
  models::explain::Candidate rocking{"reflector_rocking", "+r forward, -r back", {}, {}, 0};
  rocking.variants.resize(1);
  rocking.variants[0].block.names = {"reflector_rocking_um"};
  rocking.variants[0].block.columns.resize(2 * stations, 1);
  models::explain::Candidate drift{"angle_drift", "a trend in time", {}, {}, 0};
  drift.variants.resize(1);
  drift.variants[0].block.names = {"angle_drift_um_per_s"};
  drift.variants[0].block.columns.resize(2 * stations, 1);
  p.base.columns = Eigen::MatrixXd::Zero(2 * stations, stations);
  for (int s = 0; s < stations; ++s) p.base.names.push_back("station" + std::to_string(s + 1) + "_um");
  for (int i = 0; i < 2 * stations; ++i) {
    const bool back = i >= stations;
    const int station = back ? 2 * stations - 1 - i : i;
    p.base.columns(i, station) = 1.0;
    rocking.variants[0].block.columns(i, 0) = back ? -1.0 : 1.0;
    drift.variants[0].block.columns(i, 0) = 2.0 * i;
    const double y = geometry[static_cast<std::size_t>(station)] + (back ? -0.3 : 0.3) + 0.05 * gauss(rng);
    p.samples.push_back({back ? 1u : 0u, y, static_cast<double>(station), 2.0 * i});
    p.station_of.push_back(static_cast<std::size_t>(station));
  }
  p.candidates = {rocking, drift};
  return p;
}

}  // namespace

// Issue 41 items 3 and 7: a term per station fitted out of the data (each sample and column less its station's
// mean) is the same model as the term per station given as columns: the same finding, value, u, p-value and BIC
// difference, the same baseline RMS and parameter count, at the cost of a pass over the samples instead of a
// factored n x stations base. The held-out folds differ by design (whole stations, their disagreement predicted).
TEST(ExplainEngine, ATermPerStationFittedOutIsTheTermPerStationAsColumns) {
  const auto columns = per_station_problem(11);
  auto absorbed = columns;
  absorbed.base = {};
  absorbed.base.columns.resize(static_cast<Eigen::Index>(absorbed.samples.size()), 0);
  models::explain::absorb_station_means(absorbed);
  EXPECT_TRUE(absorbed.station_means_absorbed);
  const auto a = models::explain::explain(columns), b = models::explain::explain(absorbed);
  ASSERT_EQ(a.findings.size(), 1u) << models::explain::to_text(a);
  ASSERT_EQ(b.findings.size(), 1u) << models::explain::to_text(b);
  EXPECT_EQ(b.findings[0].effect, "reflector_rocking");
  EXPECT_EQ(a.findings[0].effect, b.findings[0].effect);
  const auto& pa = a.findings[0].parameters[0];
  const auto& pb = b.findings[0].parameters[0];
  EXPECT_NEAR(pb.value, 0.3, 4 * pb.u);
  EXPECT_NEAR(pb.value, pa.value, 1e-9 * std::abs(pa.value));
  EXPECT_NEAR(pb.u, pa.u, 1e-6 * pa.u);
  EXPECT_NEAR(b.findings[0].delta_bic, a.findings[0].delta_bic, 1e-6 * std::abs(a.findings[0].delta_bic));
  EXPECT_NEAR(b.baseline.rms_um, a.baseline.rms_um, 1e-9 * a.baseline.rms_um);
  EXPECT_EQ(b.baseline.parameters, a.baseline.parameters);
  EXPECT_NE(b.heldout_scheme.find("all its readings"), std::string::npos) << b.heldout_scheme;
  // The drift is listed with its verdict in both.
  for (const auto* rep : {&a, &b})
    EXPECT_TRUE(std::any_of(rep->considered.begin(), rep->considered.end(),
                            [](const auto& c) { return c.effect == "angle_drift"; }))
        << models::explain::to_text(*rep);
}

// A column that is a function of the station (a wave the passes share) has nothing beyond the stations' terms: it
// is zeroed, not left at rounding (which a test could take for a column of noise), and its candidate is listed as
// one that cannot be fitted.
TEST(ExplainEngine, AColumnOfTheStationAloneIsNothingOnceTheStationsAreFittedOut) {
  auto p = per_station_problem(12);
  p.base = {};
  p.base.columns.resize(static_cast<Eigen::Index>(p.samples.size()), 0);
  models::explain::Candidate wave{"pitch_wave", "the same at every reading of a station", {}, {}, 0};
  wave.variants.resize(1);
  wave.variants[0].block.names = {"wave_um"};
  wave.variants[0].block.columns.resize(static_cast<Eigen::Index>(p.samples.size()), 1);
  for (std::size_t i = 0; i < p.samples.size(); ++i) {
    const double phase = 0.3 * static_cast<double>(p.station_of[i]) + 0.1;
    wave.variants[0].block.columns(static_cast<Eigen::Index>(i), 0) = std::sin(phase);
  }
  p.candidates.push_back(wave);
  models::explain::absorb_station_means(p);
  EXPECT_EQ(p.candidates.back().variants[0].block.columns.norm(), 0.0);
  const auto rep = models::explain::explain(p);
  const auto it = std::find_if(rep.considered.begin(), rep.considered.end(),
                               [](const auto& c) { return c.effect == "pitch_wave"; });
  ASSERT_TRUE(it != rep.considered.end()) << models::explain::to_text(rep);
  EXPECT_EQ(it->verdict.rfind("cannot be fitted", 0), 0u) << it->verdict;
}

// Issue 41 item 4: every candidate is in `considered` with its verdict, also one the problem offers no form of.
TEST(ExplainEngine, ACandidateWithNoFormIsListedWithWhy) {
  auto p = make_problem([](int) { return 0.0; }, 8);
  p.candidates.push_back({"thermal_drift", "no form of it here", {}, {}, 0});
  const auto rep = models::explain::explain(p);
  const auto it = std::find_if(rep.considered.begin(), rep.considered.end(),
                               [](const auto& c) { return c.effect == "thermal_drift"; });
  ASSERT_TRUE(it != rep.considered.end()) << models::explain::to_text(rep);
  EXPECT_EQ(it->verdict, "cannot be fitted: the problem offers no form of it");
}

// Issue 41 item 10: the reading's offsets after a place set aside are its step (in its run and every later one) and,
// apart, the level of the runs after it (a ball that slips may stay slipped or be seated again between runs); a place
// in the last run has the step alone, one at a run's end the step alone (there it is that level). The step alone left
// the later runs' level to a candidate that differs between runs (a lateral play's ccw/cw level).
TEST(ExplainEngine, TheOffsetsAfterAPlaceAreAStepInItsRunAndALevelOfTheRunsAfter) {
  using models::explain::engine::later_runs;
  using Column = std::pair<std::size_t, std::size_t>;
  models::explain::Problem p = make_problem([](int) { return 0.0; }, 5);
  p.runs = {{"a", 1, 1000, "g", "", 0.0}, {"b", -1, 1000, "g", "", 0.0}};
  for (int i = 0; i < n; ++i) p.samples[static_cast<std::size_t>(i)].run = i < n / 2 ? 0u : 1u;
  std::vector<bool> keep(n, true);
  std::fill(keep.begin() + 690, keep.begin() + 710, false);
  const auto columns = models::explain::engine::fitted_offsets(p, keep, {{0, 710}});
  ASSERT_EQ(columns.size(), 2u);
  EXPECT_EQ(columns[0], (Column{0, 710}));
  EXPECT_EQ(columns[1], (Column{0, later_runs}));
  const auto reduced = models::explain::engine::without_samples(p, keep, columns);
  const Eigen::MatrixXd& base = reduced.problem.base.columns;
  ASSERT_EQ(base.cols(), p.base.columns.cols() + 2);
  // Kept sample 0 (run a, before the place), 690 (the first after it, sample 710), n - 20 - 1 (run b's last).
  const auto last = static_cast<Eigen::Index>(n - 21);
  EXPECT_EQ(base(0, 3), 0.0);
  EXPECT_EQ(base(690, 3), 1.0);
  EXPECT_EQ(base(last, 3), 1.0);
  EXPECT_EQ(base(690, 4), 0.0);
  EXPECT_EQ(base(last, 4), 1.0);
  // A place in the last run: its step alone (no run after it); one at a run's end: its step, which is that level.
  std::vector<bool> late(n, true);
  std::fill(late.begin() + 1490, late.begin() + 1510, false);
  EXPECT_EQ(models::explain::engine::fitted_offsets(p, late, {{1, 1510}}), (std::vector<Column>{{1, 1510}}));
  std::vector<bool> end(n, true);
  std::fill(end.begin() + 980, end.begin() + 1000, false);
  EXPECT_EQ(models::explain::engine::fitted_offsets(p, end, {{0, 1000}}), (std::vector<Column>{{0, 1000}}));
}

namespace {

// A decay after each of 8 events (every 250 samples) on a constant, noise 0.05: one candidate whose decay is searched
// on {20, 40} samples, with the variant a step past its upper end (80) beside the 40; the truth decays in `decay`.
models::explain::Problem decay_problem(double decay, unsigned seed) {
  models::explain::Problem p;
  p.model = "synthetic";
  p.domain = "angle_deg";
  p.runs.push_back({"run1", 1, 1000, "g", "", 0.0});
  const auto shape = [](int i, double tau) { return std::exp(-(i % 250) / tau); };
  const auto variant = [&](double tau) {
    models::explain::Variant v;
    v.block.names = {"spike_um"};
    v.block.columns.resize(n, 1);
    for (int i = 0; i < n; ++i) v.block.columns(i, 0) = shape(i, tau);
    v.fixed.push_back({"spike_decay_samples", tau, std::nan("")});
    v.searched = 1;
    return v;
  };
  models::explain::Candidate c{"reversal_spike", "a decay after each event", {}, {}, 0};
  c.variants = {variant(20), variant(40)};
  c.variants[1].beyond.push_back(variant(80));
  p.candidates = {c};
  p.base.names = {"offset_um"};
  p.base.columns = Eigen::MatrixXd::Ones(n, 1);
  std::mt19937_64 rng(seed);
  for (int i = 0; i < n; ++i)
    p.samples.push_back({0, 1.0 + 0.5 * shape(i, decay) + 0.05 * gauss(rng), 0.18 * i, 0.01 * i});
  return p;
}

}  // namespace

// Issue 41 item 10: no finding with a searched parameter on its grid's edge unless the data put the optimum there. A
// decay of 40 samples (the grid's end) is found, the step past it (80) fitting worse; one of 80 (past the grid) is
// not: the grid's best is its end, 80 fits better, and `considered` says so.
TEST(ExplainEngine, AFindingAtItsGridsEdgeIsTakenOnlyWhereAStepPastItFitsWorse) {
  models::explain::ExplainOptions o;
  o.max_set_aside = 0;  // the 80-sample decays left unexplained stay so (not set aside: the point is the verdict)
  const auto at = models::explain::explain(decay_problem(40, 3), o);
  ASSERT_EQ(at.findings.size(), 1u) << models::explain::to_text(at);
  std::map<std::string, double> v;
  for (const auto& q : at.findings[0].parameters) v[q.name] = q.value;
  EXPECT_EQ(v["spike_decay_samples"], 40.0);
  EXPECT_NEAR(v["spike_um"], 0.5, 0.02);
  const auto past = models::explain::explain(decay_problem(80, 3), o);
  EXPECT_TRUE(past.findings.empty()) << models::explain::to_text(past);
  ASSERT_EQ(past.considered.size(), 1u) << models::explain::to_text(past);
  EXPECT_NE(past.considered[0].verdict.find("spike_decay_samples = 40 is at its grid's edge and 80"), std::string::npos)
      << past.considered[0].verdict;
}

namespace {

// What step 5's rival of a first pass is judged on (explain.cpp step_to_set_aside): the first pass over the problem
// (nothing set aside), the strongest step in a run's level it leaves, and whether the base with that step's offsets
// beside a subset of the first pass's findings could beat the pass by the BIC.
struct StepJudged {
  models::explain::engine::Pass first;
  std::optional<models::explain::engine::LevelStep> step;
  bool could_win = false;
};
StepJudged judge_step(const models::explain::Problem& p) {
  namespace engine = models::explain::engine;
  models::explain::ExplainOptions o;
  o.curve_points = 0;
  StepJudged out{engine::explain_once(p, o), std::nullopt, false};
  out.step = engine::level_step(p, out.first.report.noise_um, o.alpha);
  if (!out.step) return out;
  const std::vector<bool> all(p.samples.size(), true);
  const auto after = engine::fitted_offsets(p, all, {{out.step->run, out.step->at}});
  out.could_win = engine::step_could_win(p, after, out.first);
  return out;
}

}  // namespace

// Issue 41 item 10: whether a step in a run's level could replace a first pass's findings (step_could_win), judged
// without a search. A level that steps by 1 um at sample 1300 and stays, beside the 0.3 um square wave: whatever the
// first pass took, the base with the step's offset beside its findings fits far better, so the step could win. The
// square wave alone: the strongest step the base leaves is one of its edges, which stands only for what the square
// wave the first pass found explains: it cannot win, and no second pass would be run.
TEST(ExplainEngine, AStepInARunsLevelCouldWinOnlyWhereTheFindingsDoNotExplainIt) {
  const auto stays = judge_step(make_problem([](int i) { return 0.3 * step_of(i) + (i >= 1300 ? 1.0 : 0.0); }, 4));
  ASSERT_TRUE(stays.step.has_value());
  // Beside the base alone (its harmonic takes part of the step, the square wave is left in) near the planted one.
  EXPECT_NEAR(static_cast<double>(stays.step->at), 1300.0, 25.0);
  EXPECT_GT(stays.step->place.peak_um, 0.5);
  EXPECT_TRUE(stays.could_win) << models::explain::to_text(stays.first.report);

  const auto square = judge_step(make_problem([](int i) { return 0.6 * step_of(i); }, 4));
  ASSERT_EQ(square.first.report.findings.size(), 1u) << models::explain::to_text(square.first.report);
  EXPECT_EQ(square.first.report.findings[0].effect, "backlash");
  ASSERT_TRUE(square.step.has_value());  // an edge of the square wave: (at % 250) near 0
  const std::size_t edge = square.step->at % 250;
  EXPECT_TRUE(edge < 5 || edge > 245) << square.step->at;
  EXPECT_FALSE(square.could_win);
}
