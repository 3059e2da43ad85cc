// servo_lag: both drives follow the command late by their position loop's time constant.
#include <memory>
#include <utility>

#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// The base's prediction seen where the drives were, lag behind the command: -dir omega dy/dzeta per ms of
// lag (the reading at the drive's angle zeta - dir omega lag, to first order). The base is refitted to the
// rows in use, so a held-out row's y does not reach the column.
std::vector<Variant> lag_variant(const BasePredictions& base, const std::vector<Geo>& gg,
                                 const std::vector<bool>& use) {
  const auto shared = base.of(use);
  const Eigen::VectorXd& predicted = *shared;
  if (predicted.size() == 0) return {};
  Variant v;
  v.block.names = {results::name(results::servo_lag)};
  v.block.columns = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(gg.size()), 1);
  for (std::size_t i = 0; i < gg.size(); ++i) {
    // Central differences along the run (one-sided at its ends).
    const std::size_t lo = i > 0 && gg[i - 1].run == gg[i].run ? i - 1 : i;
    const std::size_t hi = i + 1 < gg.size() && gg[i + 1].run == gg[i].run ? i + 1 : i;
    const double dz = gg[hi].zeta_rad - gg[lo].zeta_rad;
    if (hi == lo || dz == 0.0) continue;
    const double slope = (predicted[static_cast<Eigen::Index>(hi)] - predicted[static_cast<Eigen::Index>(lo)]) / dz;
    v.block.columns(static_cast<Eigen::Index>(i), 0) = -gg[i].dir * gg[i].omega_rad_per_s * slope * 1e-3;
  }
  return {v};
}

// Only where the angles are the commanded ones (a delay grid is searched) and the base is refitted.
bool servo_lag_dbb_term(const DbbTerms& t, Candidate& c) {
  if (t.tracks->size() <= 1 || !t.base) return false;
  c.generate = [base = t.base, geo = t.geo](const Eigen::VectorXd&, const std::vector<bool>& use) {
    return lag_variant(*base, *geo, use);
  };
  return true;
}

}  // namespace

extern const Effect servo_lag{
    {"servo_lag",
     "both drives follow the command late by their position loop's time constant (1/Kv)",
     "direction and feed",
     "where a run's angles are the commanded ones, every position-dependent error is seen where the drives were, "
     "a lag times the feed earlier along the path: the base's shape shifted by an angle that flips with direction "
     "and grows with feed",
     {},
     {"dbb"}},
    {"the drives follow the command late (the position loops' 1/Kv), so with the commanded angles every "
     "position-dependent error is seen a little earlier along the path, opposite in the two directions",
     &servo_lag_dbb_term},
    {},
    true};

}  // namespace guideway::models::explain::effects
