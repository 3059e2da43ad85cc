// spindle_axial_runout: the spindle moves axially with its rotation (bearing waviness).
#include <cmath>
#include <limits>
#include <numbers>

#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/profile_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// Once and twice per spindle revolution in the time of the cut.
bool spindle_axial_runout_profile_term(const ProfileTerms& t, Candidate& c) {
  for (int harmonic : {1, 2}) {
    Variant v = make_variant(t.g, {results::name(results::runout_sin), results::name(results::runout_cos)},
                             [harmonic](const Pt& p, double* o) {
                               const double th = harmonic * 2 * std::numbers::pi * p.rpm / 60.0 * p.t_s;
                               o[0] = std::sin(th);
                               o[1] = std::cos(th);
                             });
    v.fixed.push_back({results::name(results::runout_per_rev), static_cast<double>(harmonic),
                       std::numeric_limits<double>::quiet_NaN()});
    v.searched = 1;
    v.report = [](const Eigen::VectorXd& x, const Eigen::MatrixXd& cov) {
      return amp_phase(results::name(results::spindle_axial_runout), results::name(results::spindle_axial_runout_phase),
                       x, cov);
    };
    c.variants.push_back(std::move(v));
  }
  return true;
}

}  // namespace

extern const Effect spindle_axial_runout{
    {"spindle_axial_runout",
     "the spindle moves axially twice per revolution (bearing waviness)",
     "spindle angle (time)",
     "a sinusoid at twice the spindle frequency on a faced surface",
     {},
     {"flatness", "straightness"}},
    {},
    {"the spindle moves axially with its rotation (bearing waviness), a sinusoid at a multiple of the spindle "
     "frequency in the time of the cut",
     &spindle_axial_runout_profile_term}};

}  // namespace guideway::models::explain::effects
