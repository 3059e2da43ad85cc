// backlash: lost motion in the drives at each reversal.
#include <algorithm>
#include <limits>

#include <Eigen/QR>

#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// The step and deadband variants from the current residual `r` (rows `use`): the ideal step, then for each
// drive delay the deadband response at the width the step suggests, refined once by a fit of the response.
std::vector<Variant> backlash_variants(const std::vector<Geo>& gg, const std::vector<std::string>& names,
                                       const std::vector<dbb::DriveTrack>& tracks, const Eigen::VectorXd& r,
                                       const std::vector<bool>& use) {
  std::vector<Variant> vs;
  vs.push_back(make_variant(gg, names, [](const Geo& p, double* o) {
    o[0] = -p.lambda * 0.5 * p.sgn_a * p.c;
    o[1] = -p.lambda * 0.5 * p.sgn_b * p.s;
  }));
  // Sizes from the rows in use only (a held-out row's zero residual would shrink them).
  const std::vector<Eigen::Index> rows = rows_in_use(use);
  const Eigen::VectorXd rr = r(rows);
  const auto sizes = [&](const Variant& v) {
    const Eigen::MatrixXd x = v.block.columns(rows, Eigen::all);
    const Eigen::Vector2d b = x.colPivHouseholderQr().solve(rr);
    return std::array<double, 2>{std::max(0.0, b[0]) * 1e-6, std::max(0.0, b[1]) * 1e-6};
  };
  const auto response = [&](std::array<double, 2> b, const dbb::DriveTrack& track) {
    Variant v;
    v.block.names = names;
    v.block.columns.resize(static_cast<Eigen::Index>(gg.size()), 2);
    for (std::size_t i = 0; i < gg.size(); ++i) {
      const auto m = dbb::lost_motion(track, i, b[0], b[1]);
      v.block.columns(static_cast<Eigen::Index>(i), 0) = gg[i].lambda * m[0] * gg[i].c;
      v.block.columns(static_cast<Eigen::Index>(i), 1) = gg[i].lambda * m[1] * gg[i].s;
    }
    if (tracks.size() > 1) {
      v.fixed.push_back(
          {results::name(results::backlash_delay), track.delay_s * 1e3, std::numeric_limits<double>::quiet_NaN()});
      v.searched = 1;
    }
    return v;
  };
  const auto step = sizes(vs.front());
  if (step[0] > 0 || step[1] > 0) {
    for (const dbb::DriveTrack& track : tracks) {
      // The width the step suggests, then once more from a fit of the response at that width.
      Variant first = response(step, track);
      const auto refined = sizes(first);
      vs.push_back(refined[0] > 0 || refined[1] > 0 ? response(refined, track) : std::move(first));
    }
  }
  return vs;
}

// Ideal step first (actual a = commanded a - (b/2) sign(da/dt)); then, from the current residual, the
// deadband response at the width the step suggests (the step alone biases it and leaves an inward spike
// at every reversal that another candidate would otherwise claim), for each drive delay of the grid.
bool backlash_dbb_term(const DbbTerms& t, Candidate& c) {
  const std::vector<std::string> names{results::name(results::backlash, t.plane, 0),
                                       results::name(results::backlash, t.plane, 1)};
  const auto geo = std::make_shared<const std::vector<Geo>>(t.g);
  const auto tracks = t.tracks;
  c.generate = [geo, names, tracks](const Eigen::VectorXd& r, const std::vector<bool>& use) {
    return backlash_variants(*geo, names, *tracks, r, use);
  };
  c.search_size = 1 + tracks->size();
  return true;
}

}  // namespace

extern const Effect backlash{
    {"backlash",
     "lost motion in the drive: the axis stays behind the command by half the play, on the side it came from",
     "reversal of an axis",
     "a step of the play at each reversal of the axis, opposite on the two sides of the circle",
     {},
     {"dbb"}},
    {"lost motion in the drives: at each reversal an axis stays behind the command by half its play",
     &backlash_dbb_term},
    {}};

}  // namespace guideway::models::explain::effects
