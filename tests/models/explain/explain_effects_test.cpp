// EXPLAIN's effect library (models/explain/effects/, one file per effect): every entry is whole and named
// once, each model's terms are those its entry claims, every candidate the DBB and profile front ends
// offer is an effect of the library (effect_info) with the sentence of its file, and every parameter name a
// candidate reports is in the catalogue of parameters (results/parameters.hpp).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "models/explain/dbb_explain.hpp"
#include "models/explain/effects.hpp"
#include "models/explain/effects/effect.hpp"
#include "models/explain/explain.hpp"
#include "models/explain/profile_explain.hpp"
#include "models/explain/runout_explain.hpp"
#include "models/explain/traverse_explain.hpp"
#include "profile_test_support.hpp"
#include "results/parameters.hpp"
#include "simulators/machine/dbb_runs.hpp"
#include "simulators/machine/machine.hpp"

using namespace guideway;
using models::explain::effects::Effect;

namespace {

bool claims(const models::explain::EffectInfo& info, const std::string& model) {
  return std::find(info.terms.begin(), info.terms.end(), model) != info.terms.end();
}

// A CCW and a CW circle of the default virtual machine, sparsely sampled (the names, not the fit, matter).
std::vector<formats::DbbRun> dbb_runs() {
  const simulators::machine::Machine machine(simulators::machine::MachineConfig{});
  std::vector<formats::DbbRun> runs;
  for (const auto direction : {formats::DbbDirection::ccw, formats::DbbDirection::cw}) {
    simulators::machine::DbbCircleSpec spec;
    spec.direction = direction;
    spec.sample_rate_hz = 20;
    runs.push_back(simulators::machine::simulate_dbb_run(machine, spec, "run" + std::to_string(runs.size() + 1)));
  }
  return runs;
}

// Two faced profiles at two feeds (the X carriage's traverse gives abbe_offset a term).
std::vector<models::explain::ProfileRun> profiles() {
  int i = 0;
  return test::two_cuts([&](double x) { return 5e-6 * x + 1e-8 * std::sin(3000 * x + static_cast<double>(i++ % 7)); });
}

models::flatness::AngleTraverse traverse() {
  models::flatness::AngleTraverse t;
  t.source = "t.csv";
  t.step_m = 1e-3;
  for (int k = 0; k < 22; ++k) {
    t.x_m.push_back(k * 1e-3 - 1e-3);
    t.pitch_rad.push_back(4e-6 * k + 3e-7 * k * k);
    t.line.push_back(static_cast<std::size_t>(k + 3));
  }
  return t;
}

// Every name a candidate reports: its blocks' columns and searched values, from its fixed variants or
// what its generator makes of a residual.
std::set<std::string> reported_names(const models::explain::Candidate& c, std::size_t n) {
  std::vector<models::explain::Variant> variants = c.variants;
  if (c.generate) {
    Eigen::VectorXd r(static_cast<Eigen::Index>(n));
    for (Eigen::Index i = 0; i < r.size(); ++i) r[i] = std::sin(0.37 * static_cast<double>(i));
    const auto made = c.generate(r, std::vector<bool>(n, true));
    variants.insert(variants.end(), made.begin(), made.end());
  }
  std::set<std::string> names;
  for (const auto& v : variants) {
    names.insert(v.block.names.begin(), v.block.names.end());
    for (const auto& f : v.fixed) names.insert(f.name);
    if (v.report) {
      const auto q = static_cast<Eigen::Index>(v.block.names.size());
      for (const auto& p : v.report(Eigen::VectorXd::Ones(q), Eigen::MatrixXd::Identity(q, q))) names.insert(p.name);
    }
  }
  return names;
}

// The candidates of `problem` against the library: each an effect of it that claims the model, with its
// file's sentence and catalogued names; returns their names.
template <class Terms>
std::set<std::string> check_candidates(const models::explain::Problem& problem, const std::string& model,
                                       models::explain::effects::Term<Terms> Effect::*term) {
  std::set<std::string> names;
  for (const auto& c : problem.candidates) {
    SCOPED_TRACE(c.effect);
    EXPECT_NO_THROW((void)models::explain::effect_info(c.effect));
    EXPECT_TRUE(claims(models::explain::effect_info(c.effect), model));
    const Effect* e = models::explain::effects::find(c.effect);
    EXPECT_NE(e, nullptr);
    if (e != nullptr) {
      EXPECT_EQ(c.why, (e->*term).why);
    }
    EXPECT_TRUE(names.insert(c.effect).second) << "offered twice";
    for (const auto& name : reported_names(c, problem.samples.size()))
      EXPECT_NE(results::find_parameter(name), nullptr) << name << " is not in results/parameters.hpp";
  }
  return names;
}

}  // namespace

TEST(ExplainEffects, LibraryEntriesAreWholeAndNamedOnce) {
  std::set<std::string> names;
  for (const auto& info : models::explain::effect_library()) {
    SCOPED_TRACE(info.name);
    EXPECT_TRUE(names.insert(info.name).second);
    EXPECT_FALSE(info.meaning.empty());
    EXPECT_FALSE(info.domain.empty());
    EXPECT_FALSE(info.signature.empty());
    EXPECT_EQ(&models::explain::effect_info(info.name).name, &models::explain::effects::find(info.name)->info.name);
  }
  EXPECT_EQ(names.size(), models::explain::effects::library().size());
  EXPECT_THROW((void)models::explain::effect_info("no_such_effect"), std::out_of_range);
}

TEST(ExplainEffects, EachModelsTermsAreThoseItsEntryClaims) {
  for (const Effect* e : models::explain::effects::library()) {
    SCOPED_TRACE(e->info.name);
    EXPECT_EQ(e->dbb.build != nullptr, claims(e->info, "dbb"));
    EXPECT_EQ(e->profile.build != nullptr, claims(e->info, "flatness") || claims(e->info, "straightness"));
    EXPECT_EQ(e->dbb.build != nullptr, !e->dbb.why.empty());
    EXPECT_EQ(e->profile.build != nullptr, !e->profile.why.empty());
    EXPECT_EQ(e->runout.build != nullptr, claims(e->info, "runout"));
    EXPECT_EQ(e->runout.build != nullptr, !e->runout.why.empty());
    EXPECT_EQ(e->traverse.build != nullptr, claims(e->info, "traverse"));
    EXPECT_EQ(e->traverse.build != nullptr, !e->traverse.why.empty());
    for (const auto& base : e->info.in_base_of) EXPECT_FALSE(claims(e->info, base)) << base << ": base and candidate";
  }
}

TEST(ExplainEffects, EveryDbbCandidateIsALibraryEffect) {
  const auto runs = dbb_runs();
  const auto offered = check_candidates(models::explain::dbb_problem(runs), "dbb", &Effect::dbb);
  // Commanded angles (no angle_source = encoders): the drives' delay is searched and servo_lag offered.
  std::set<std::string> expected;
  for (const auto& info : models::explain::effect_library())
    if (claims(info, "dbb")) expected.insert(info.name);
  EXPECT_EQ(offered, expected);
}

TEST(ExplainEffects, EveryProfileCandidateIsALibraryEffect) {
  const auto t = traverse();
  const auto offered =
      check_candidates(models::explain::profile_problem(profiles(), "flatness", &t), "flatness", &Effect::profile);
  std::set<std::string> expected;
  for (const auto& info : models::explain::effect_library())
    if (claims(info, "flatness")) expected.insert(info.name);
  EXPECT_EQ(offered, expected);
  // Without a measured pitch abbe_offset has no term.
  const auto straightness =
      check_candidates(models::explain::profile_problem(profiles(), "straightness"), "straightness", &Effect::profile);
  EXPECT_EQ(straightness.count("abbe_offset"), 0U);
  EXPECT_EQ(straightness.size(), expected.size() - 1);
}

TEST(ExplainEffects, EveryRunoutCandidateIsALibraryEffect) {
  models::explain::RunoutRecord r;
  r.source = "r.csv";
  r.rpm = 60;
  for (int k = 0; k < 200; ++k) {
    r.angle_rad.push_back(2 * std::numbers::pi * k / 40.0);
    r.runout_m.push_back(1e-7 * std::cos(r.angle_rad.back()) + 1e-9 * std::sin(0.37 * k));
  }
  const auto offered = check_candidates(models::explain::runout_problem({r}), "runout", &Effect::runout);
  std::set<std::string> expected;
  for (const auto& info : models::explain::effect_library())
    if (claims(info, "runout")) expected.insert(info.name);
  EXPECT_EQ(expected, (std::set<std::string>{"artifact_form", "asynchronous_line", "speed_ripple", "speed_variation",
                                             "synchronous_harmonic", "thermal_drift"}));
  // The artifact's form has a term only with a reversal: a second record, the artifact turned.
  expected.erase("artifact_form");
  EXPECT_EQ(offered, expected);
  models::explain::RunoutRecord turned = r;
  r.artifact_turned_rad = 0.0;
  turned.artifact_turned_rad = std::numbers::pi;
  expected.insert("artifact_form");
  EXPECT_EQ(check_candidates(models::explain::runout_problem({r, turned}), "runout", &Effect::runout), expected);
}

TEST(ExplainEffects, EveryTraverseCandidateIsALibraryEffect) {
  // A forward and a return pass of 40 readings with times and yaw: every traverse term has what it needs.
  std::vector<models::explain::TraversePass> passes(2);
  for (int d = 0; d < 2; ++d) {
    auto& p = passes[static_cast<std::size_t>(d)];
    p.source = "t.csv pass " + std::to_string(d + 1);
    p.direction = d == 0 ? 1 : -1;
    p.step_m = 0.01;
    for (int k = 0; k < 40; ++k) {
      const int station = d == 0 ? k : 39 - k;
      p.x_m.push_back(0.01 * station);
      p.t_s.push_back(2.0 * (d * 45 + k));
      p.pitch_rad.push_back(1e-6 * station + 1e-8 * std::sin(0.37 * k + d));
      p.yaw_rad.push_back(2e-7 * std::cos(0.9 * station));
    }
  }
  const auto offered = check_candidates(models::explain::traverse_problem(passes), "traverse", &Effect::traverse);
  std::set<std::string> expected;
  for (const auto& info : models::explain::effect_library())
    if (claims(info, "traverse")) expected.insert(info.name);
  EXPECT_EQ(offered, expected);
  EXPECT_EQ(expected, (std::set<std::string>{"angle_drift", "pitch_wave", "reflector_rocking", "yaw_coupling"}));
}
