// backlash: lost motion in the drives at each reversal.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>

#include <Eigen/QR>

#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// What the generator needs of the geometry, per sample, in arrays of their own (a sample's whole geometry is
// ten times larger: the generator runs in every fold of every held-out test), and the ideal step, which does
// not depend on the residual.
struct Shapes {
  std::vector<double> lambda, c, s;
  Eigen::MatrixXd step;                     // n x 2
  std::shared_ptr<const std::vector<Geo>> geo;  // where a track's rise is made again (dbb::lost_motion)
  // The track a delay step past the grid's last (delay_past_grid_s), one, for Variant::beyond; null where no delay
  // is searched. Made once: one more delay's track, the generator's other tracks are the problem's.
  std::shared_ptr<const std::vector<dbb::DriveTrack>> past;
};

// The deadband response of widths b (m) on drive track `track` over every sample, made on demand (its lost
// motion per sample is cheaper to make again than to keep: the generator offers one per delay in every fold); its
// delay reported as searched where `delay_searched`.
Variant response_variant(const std::shared_ptr<const Shapes>& sh, const std::vector<std::string>& names,
                         const std::shared_ptr<const std::vector<dbb::DriveTrack>>& tracks, std::size_t track,
                         std::array<double, 2> b, bool delay_searched) {
  Variant v;
  v.block.names = names;
  v.fill = [sh, tracks, track, b](Eigen::Ref<Eigen::MatrixXd> out) {
    const dbb::DriveTrack& t = (*tracks)[track];
    for (std::size_t i = 0; i < sh->lambda.size(); ++i) {
      const auto m = dbb::lost_motion(t, (*sh->geo)[i], i, b[0], b[1]);
      out(static_cast<Eigen::Index>(i), 0) = sh->lambda[i] * m[0] * sh->c[i];
      out(static_cast<Eigen::Index>(i), 1) = sh->lambda[i] * m[1] * sh->s[i];
    }
  };
  if (delay_searched) {
    v.fixed.push_back({results::name(results::backlash_delay), (*tracks)[track].delay_s * 1e3,
                       std::numeric_limits<double>::quiet_NaN()});
    v.searched = 1;
  }
  return v;
}

// The step and deadband variants from the current residual `r` (rows `use`): the ideal step, then for each
// drive delay the deadband response at the width the step suggests, refined once by a fit of the response. The grid's
// last delay carries the response a step past it, made the same way (Variant::beyond), where every row is in use: the
// edge is judged on all the data (the forward step, drop-one), never in a held-out fold. Its first, 0, is no edge
// (delay_past_grid_s).
std::vector<Variant> backlash_variants(const std::shared_ptr<const Shapes>& sh, const std::vector<std::string>& names,
                                       const std::shared_ptr<const std::vector<dbb::DriveTrack>>& tracks,
                                       const Eigen::VectorXd& r, const std::vector<bool>& use) {
  std::vector<Variant> vs(1);
  vs[0].block.names = names;
  vs[0].fill = [sh](Eigen::Ref<Eigen::MatrixXd> out) { out = sh->step; };
  // Sizes from the rows in use only (a held-out row's zero residual would shrink them).
  const std::vector<Eigen::Index> rows = rows_in_use(use);
  const Eigen::VectorXd rr = r(rows);
  const auto sizes = [&](const Eigen::MatrixXd& x) {  // x: the variant's columns on `rows`
    const Eigen::Vector2d b = x.colPivHouseholderQr().solve(rr);
    return std::array<double, 2>{std::max(0.0, b[0]) * 1e-6, std::max(0.0, b[1]) * 1e-6};
  };
  // The deadband response's columns at the rows in use.
  const auto response_on_rows = [&](std::array<double, 2> b, const dbb::DriveTrack& track) {
    Eigen::MatrixXd x(static_cast<Eigen::Index>(rows.size()), 2);
    for (std::size_t k = 0; k < rows.size(); ++k) {
      const auto i = static_cast<std::size_t>(rows[k]);
      const auto m = dbb::lost_motion(track, (*sh->geo)[i], i, b[0], b[1]);
      x(static_cast<Eigen::Index>(k), 0) = sh->lambda[i] * m[0] * sh->c[i];
      x(static_cast<Eigen::Index>(k), 1) = sh->lambda[i] * m[1] * sh->s[i];
    }
    return x;
  };
  const auto step = sizes(sh->step(rows, Eigen::all));
  // The width the step suggests, then once more from a fit of the response at that width: the first response is
  // needed on the rows in use only.
  const auto refined = [&](const dbb::DriveTrack& track) {
    const auto b = sizes(response_on_rows(step, track));
    return b[0] > 0 || b[1] > 0 ? b : step;
  };
  if (step[0] > 0 || step[1] > 0) {
    const bool searched = tracks->size() > 1;
    const bool every_row = rows.size() == use.size();
    for (std::size_t k = 0; k < tracks->size(); ++k) {
      Variant v = response_variant(sh, names, tracks, k, refined((*tracks)[k]), searched);
      if (searched && k + 1 == tracks->size() && sh->past && every_row)
        v.beyond.push_back(response_variant(sh, names, sh->past, 0, refined(sh->past->front()), true));
      vs.push_back(std::move(v));
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
  auto shapes = std::make_shared<Shapes>();
  for (auto* v : {&shapes->lambda, &shapes->c, &shapes->s}) v->reserve(t.g.size());
  for (const Geo& p : t.g) {
    shapes->lambda.push_back(p.lambda);
    shapes->c.push_back(p.c);
    shapes->s.push_back(p.s);
  }
  shapes->step = make_variant(t.g, names, [](const Geo& p, double* o) {
                   o[0] = -p.lambda * 0.5 * p.sgn_a * p.c;
                   o[1] = -p.lambda * 0.5 * p.sgn_b * p.s;
                 }).block.columns;
  shapes->geo = t.geo;
  if (const double past_s = delay_past_grid_s(*t.tracks); std::isfinite(past_s))
    shapes->past = effects::drive_tracks(t.g, std::vector<double>{past_s});
  const auto tracks = t.tracks;
  c.generate = [shapes = std::shared_ptr<const Shapes>(std::move(shapes)), names, tracks](
                   const Eigen::VectorXd& r, const std::vector<bool>& use) {
    return backlash_variants(shapes, names, tracks, r, use);
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
