// feed_marks: the round tool nose leaves a cusp every feed per revolution.
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>

#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/profile_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// The passes' position of each cut, from the residual's fundamental at the feed per revolution: the
// scallop's fundamental is -cos(2 pi (x - pass) / f), lowest at a pass, so a pass sits at the
// fundamental's phase + pi. Held-out rows have residual 0: the phase is that of the rows in use.
std::vector<double> pass_phases(const std::vector<Pt>& gg, std::size_t n_runs, const Eigen::VectorXd& r) {
  std::vector<double> sc(n_runs, 0.0), ss(n_runs, 0.0);
  for (std::size_t i = 0; i < gg.size(); ++i) {
    const double u = 2 * pi * gg[i].x_mm * gg[i].rpm / gg[i].feed_mm_per_min;
    sc[gg[i].run] += r[static_cast<Eigen::Index>(i)] * std::cos(u);
    ss[gg[i].run] += r[static_cast<Eigen::Index>(i)] * std::sin(u);
  }
  std::vector<double> phase(n_runs);
  for (std::size_t k = 0; k < n_runs; ++k) phase[k] = std::atan2(ss[k], sc[k]) + pi;
  return phase;
}

// The scallop at those passes and a quarter feed on: their fundamentals are in quadrature, so the pair
// follows any pass position near the estimate linearly, and the F-test counts the two degrees of freedom a
// free phase has (as a sine/cosine pair would), not one.
Variant scallops(const std::vector<Pt>& gg, const std::vector<double>& phase, double f1_mm) {
  const auto scallop = [phase](const Pt& p, double shift) {
    const double f = p.feed_mm_per_min / p.rpm;
    const double u = p.x_mm - (phase[p.run] / (2 * pi) + shift) * f;  // from a pass
    const double d = u - f * std::round(u / f);
    return (d * d - f * f / 12.0) / 2.0 * 1e3;  // zero mean over a feed; mm^2 / 2 x (1/mm) = mm -> um
  };
  Variant v =
      make_variant(gg, {results::name(results::nose_curvature), results::name(results::nose_curvature_quadrature)},
                   [scallop](const Pt& p, double* o) {
                     o[0] = scallop(p, 0.0);
                     o[1] = scallop(p, 0.25);
                   });
  v.report = [f1_mm](const Eigen::VectorXd& x, const Eigen::MatrixXd& cov) {
    // Curvature 1/R = the pair's amplitude; the fundamental f^2 / (2 pi^2 R) at the first cut's feed.
    const auto ap = amp_phase("k", "phase", x, cov);
    const double kappa = ap[0].value, uk = ap[0].u;
    const double to_a1 = f1_mm * f1_mm / (2 * pi * pi) * 1e3;
    return std::vector<ParamValue>{{results::name(results::feed_marks), kappa * to_a1, uk * to_a1},
                                   {results::name(results::tool_nose_radius), 1.0 / kappa, uk / (kappa * kappa)}};
  };
  return v;
}

// The round nose leaves a scallop between passes one feed per revolution f apart: height d^2 / (2R) at
// distance d from the nearest pass, i.e. all harmonics of x / f with fixed ratios ((-1)^(k+1) / k^2). One
// sinusoid would leave the second harmonic (1/4 of the first) to be claimed by a twice-per-rev
// spindle_axial_runout, which at constant feed falls at exactly that period. The passes' position is each
// cut's own: taken per run from the residual's fundamental; the nose curvature 1/R is common.
bool feed_marks_profile_term(const ProfileTerms& t, Candidate& c) {
  const auto pts = std::make_shared<const std::vector<Pt>>(t.g);
  const std::size_t n_runs = t.runs.size();
  const double f1_mm = t.runs.empty() || !(t.runs.front().spindle_rpm > 0)
                           ? std::numeric_limits<double>::quiet_NaN()
                           : t.runs.front().feed_mm_per_min / t.runs.front().spindle_rpm;
  c.generate = [pts, n_runs, f1_mm](const Eigen::VectorXd& r, const std::vector<bool>&) {
    return std::vector<Variant>{scallops(*pts, pass_phases(*pts, n_runs, r), f1_mm)};
  };
  c.search_size = 1;
  return true;
}

}  // namespace

extern const Effect feed_marks{
    {"feed_marks",
     "the round tool nose leaves a cusp every feed per revolution",
     "position",
     "a periodic profile with the feed per revolution as period",
     {},
     {"flatness", "straightness"}},
    {},
    {"the round tool nose leaves a scallop of height d^2/(2R) between passes one feed per revolution apart",
     &feed_marks_profile_term}};

}  // namespace guideway::models::explain::effects
