// cyclic_error: a lead-screw (or scale) pitch error repeating every lead along an axis.
#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <limits>
#include <memory>
#include <numbers>

#include <Eigen/Cholesky>

#include "models/dbb/fast_sincos.hpp"
#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/profile_terms.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

// Samples whose phases are made, then their sines and cosines a vector at a time (dbb::fast_sincos_batch).
constexpr std::size_t sincos_chunk = 256;

// The leads searched on a DBB circle (mm), and a step past each end (Variant::beyond): a scale's or an encoder's
// error repeats at a shorter period than any screw's lead, and a screw's lead may be longer than 40 mm.
constexpr double dbb_periods_mm[] = {1.0,  2.0,  2.5,  3.0,  4.0,  5.0,  6.0,  8.0, 10.0,
                                     12.0, 12.5, 15.0, 16.0, 20.0, 25.0, 32.0, 40.0};
constexpr double dbb_period_below_mm = 0.5, dbb_period_above_mm = 50.0;
// On a profile (mm): 1-10 searched, 0.5 and 12 a step past.
constexpr double profile_periods_mm[] = {1.0, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0};
constexpr double profile_period_below_mm = 0.5, profile_period_above_mm = 12.0;

// What the period search and the variants read, per sample: sin and cos of the commanded angle, and the projection
// of each axis on the bar.
struct Undelayed {
  std::vector<double> sz, cz, proj_a, proj_b;
  // The samples as stretches of one run, centre and radius, so that a variant reads none of them per sample (a
  // sample's whole geometry is ten times the four arrays above): where each starts, what it reads, whether it
  // starts a run (a delay's turn is made at each).
  struct Stretch {
    std::size_t from = 0;
    bool new_run = false;
    double turn = 0;  // dir omega (rad/s)
    double center_a_m = 0, center_b_m = 0, radius_m = 0;
  };
  std::vector<Stretch> stretches;  // then one past the last sample's
};

// The drives' position along `axis` at sample i when they follow the command late by an angle whose cos and sin
// are cos_d, sin_d (dir omega delay, for the sample's run): the commanded angle's sine and cosine turned back by
// it, a product instead of a sine per sample; at no delay the commanded position itself.
double delayed_position(const Geo& g, const Undelayed& u, std::size_t i, int axis, double cos_d, double sin_d) {
  return axis == 0 ? g.center_a_m + g.radius_m * (u.cz[i] * cos_d + u.sz[i] * sin_d)
                   : g.center_b_m + g.radius_m * (u.sz[i] * cos_d - u.cz[i] * sin_d);
}

// Along plane axis `axis` with period p_mm, on the drives' positions when they follow the command delay_s late.
// Made on demand (Variant::fill): a sine and cosine per sample, cheaper to make again than to keep (the generator
// offers 48 of them in every fold of every held-out test).
Variant dbb_variant(std::shared_ptr<const Undelayed> u,
                    const std::string& plane, int axis, double p_mm, double delay_s, bool delay_searched) {
  const double k = 2 * pi / (p_mm * 1e-3);
  Variant v;
  v.block.names = {results::name(results::cyclic_sin_column, plane, axis),
                   results::name(results::cyclic_cos_column, plane, axis)};
  v.fill = [u = std::move(u), axis, k, delay_s](Eigen::Ref<Eigen::MatrixXd> out) {
    const std::vector<double>& proj = axis == 0 ? u->proj_a : u->proj_b;
    const std::vector<double>&cz = u->cz, &sz = u->sz;
    double cos_d = 1, sin_d = 0;
    std::array<double, sincos_chunk> phase{}, sn{}, cs{};
    for (std::size_t st = 0; st + 1 < u->stretches.size(); ++st) {
      const Undelayed::Stretch& g = u->stretches[st];
      if (g.new_run) {
        cos_d = std::cos(g.turn * delay_s);
        sin_d = std::sin(g.turn * delay_s);
      }
      const std::size_t to = u->stretches[st + 1].from;
      for (std::size_t from = g.from; from < to; from += sincos_chunk) {
        const std::size_t m = std::min(sincos_chunk, to - from);
        // delayed_position()'s arithmetic, the stretch's centre and radius read once.
        if (axis == 0)
          for (std::size_t j = 0; j < m; ++j)
            phase[j] = k * (g.center_a_m + g.radius_m * (cz[from + j] * cos_d + sz[from + j] * sin_d));
        else
          for (std::size_t j = 0; j < m; ++j)
            phase[j] = k * (g.center_b_m + g.radius_m * (sz[from + j] * cos_d - cz[from + j] * sin_d));
        dbb::fast_sincos_batch(phase.data(), sn.data(), cs.data(), m);
        for (std::size_t j = 0; j < m; ++j) {
          out(static_cast<Eigen::Index>(from + j), 0) = proj[from + j] * sn[j];
          out(static_cast<Eigen::Index>(from + j), 1) = proj[from + j] * cs[j];
        }
      }
    }
  };
  v.fixed.push_back({results::name(results::cyclic_period, plane, axis), p_mm, nan});
  v.searched = 1;
  if (delay_searched) {
    v.fixed.push_back({results::name(results::cyclic_delay, plane, axis), delay_s * 1e3, nan});
    v.searched = 2;
  }
  v.group = results::axis_letter(plane, axis);
  const std::string amp = results::name(results::cyclic_error, plane, axis);
  const std::string phase = results::name(results::cyclic_phase, plane, axis);
  v.report = [amp, phase](const Eigen::VectorXd& x, const Eigen::MatrixXd& cov) {
    return amp_phase(amp, phase, x, cov);
  };
  return v;
}

// dbb_variant with the variants a step past the grids' ends where (p_mm, delay_s) is at one (Variant::beyond): past
// either end of the leads, and past the delays' longest (past_delay_s; NaN: no delay searched). The delays' shortest,
// 0, is no edge (delay_past_grid_s).
Variant dbb_variant_in_grid(const std::shared_ptr<const Undelayed>& u, const std::string& plane, int axis, double p_mm,
                            double delay_s, bool delay_searched, double last_delay_s, double past_delay_s) {
  Variant v = dbb_variant(u, plane, axis, p_mm, delay_s, delay_searched);
  if (p_mm == dbb_periods_mm[0])
    v.beyond.push_back(dbb_variant(u, plane, axis, dbb_period_below_mm, delay_s, delay_searched));
  if (p_mm == dbb_periods_mm[std::size(dbb_periods_mm) - 1])
    v.beyond.push_back(dbb_variant(u, plane, axis, dbb_period_above_mm, delay_s, delay_searched));
  if (delay_searched && delay_s == last_delay_s && std::isfinite(past_delay_s))
    v.beyond.push_back(dbb_variant(u, plane, axis, p_mm, past_delay_s, true));
  return v;
}

// Periods and delays: the two periods per axis whose undelayed terms explain most of the residual, each
// then tried at every delay.
std::vector<Variant> best_periods_at_every_delay(const std::shared_ptr<const std::vector<Geo>>& geo,
                                                 const std::string& plane, const std::vector<dbb::DriveTrack>& tracks,
                                                 const std::shared_ptr<const Undelayed>& u, const Eigen::VectorXd& r,
                                                 const std::vector<bool>& use) {
  const std::vector<Geo>& gg = *geo;
  const std::vector<Eigen::Index> rows = rows_in_use(use);
  std::vector<Variant> vs;
  const std::size_t per_axis = std::size(dbb_periods_mm);
  std::array<double, sincos_chunk> phase{}, sn{}, cs{};
  for (int axis = 0; axis < 2; ++axis) {
    const std::vector<double>& proj = axis == 0 ? u->proj_a : u->proj_b;
    // The undelayed position of each row in use, the same for every period.
    std::vector<double> position(rows.size());
    for (std::size_t q = 0; q < rows.size(); ++q) {
      const auto j = static_cast<std::size_t>(rows[q]);
      position[q] = delayed_position(gg[j], *u, j, axis, 1.0, 0.0);
    }
    std::vector<std::pair<double, std::size_t>> score;  // (-explained, period's index)
    for (std::size_t k = 0; k < per_axis; ++k) {
      // The 2 x 2 normal equations summed over the rows in use, the term's columns made as they are summed.
      const double kk = 2 * pi / (dbb_periods_mm[k] * 1e-3);
      Eigen::Matrix2d xtx = Eigen::Matrix2d::Zero();
      Eigen::Vector2d xtr = Eigen::Vector2d::Zero();
      for (std::size_t from = 0; from < rows.size(); from += sincos_chunk) {
        const std::size_t m = std::min(sincos_chunk, rows.size() - from);
        for (std::size_t q = 0; q < m; ++q) phase[q] = kk * position[from + q];
        dbb::fast_sincos_batch(phase.data(), sn.data(), cs.data(), m);
        for (std::size_t q = 0; q < m; ++q) {
          const Eigen::Index i = rows[from + q];
          const double s = proj[static_cast<std::size_t>(i)] * sn[q], c = proj[static_cast<std::size_t>(i)] * cs[q];
          const double ri = r[i];
          xtx(0, 0) += s * s;
          xtx(0, 1) += s * c;
          xtx(1, 1) += c * c;
          xtr[0] += s * ri;
          xtr[1] += c * ri;
        }
      }
      xtx(1, 0) = xtx(0, 1);
      score.emplace_back(-xtr.dot(xtx.ldlt().solve(xtr)), k);
    }
    std::sort(score.begin(), score.end());
    for (std::size_t k = 0; k < 2 && k < score.size(); ++k)
      for (const dbb::DriveTrack& track : tracks)
        vs.push_back(dbb_variant_in_grid(u, plane, axis, dbb_periods_mm[score[k].second], track.delay_s, true,
                                         tracks.back().delay_s, delay_past_grid_s(tracks)));
  }
  return vs;
}

bool cyclic_error_dbb_term(const DbbTerms& t, Candidate& c) {
  // The commanded positions (the drives' when read from the encoders): at the first delay, 0.
  auto u = std::make_shared<Undelayed>();
  for (auto* v : {&u->sz, &u->cz, &u->proj_a, &u->proj_b}) v->reserve(t.g.size());
  for (const Geo& g : t.g) {
    double sn = 0, cs = 0;
    dbb::fast_sincos(g.zeta_rad, sn, cs);
    u->sz.push_back(sn);
    u->cz.push_back(cs);
    u->proj_a.push_back(g.lambda * g.c);
    u->proj_b.push_back(g.lambda * g.s);
  }
  for (std::size_t i = 0; i < t.g.size(); ++i) {
    const Geo& g = t.g[i];
    const bool new_run = i == 0 || g.run != t.g[i - 1].run;
    const Undelayed::Stretch* last = u->stretches.empty() ? nullptr : &u->stretches.back();
    if (new_run || g.center_a_m != last->center_a_m || g.center_b_m != last->center_b_m || g.radius_m != last->radius_m)
      u->stretches.push_back({i, new_run, g.dir * g.omega_rad_per_s, g.center_a_m, g.center_b_m, g.radius_m});
  }
  u->stretches.push_back({t.g.size(), false, 0, 0, 0, 0});
  const std::shared_ptr<const Undelayed> shared = std::move(u);
  const double first_delay = t.tracks->front().delay_s;
  if (t.tracks->size() == 1) {
    for (int axis = 0; axis < 2; ++axis)
      for (double p_mm : dbb_periods_mm)
        c.variants.push_back(dbb_variant_in_grid(shared, t.plane, axis, p_mm, first_delay, false, first_delay, nan));
    return true;
  }
  c.generate = [geo = t.geo, plane = t.plane, tracks = t.tracks, shared](const Eigen::VectorXd& r,
                                                                         const std::vector<bool>& use) {
    return best_periods_at_every_delay(geo, plane, *tracks, shared, r, use);
  };
  c.search_size = 2 * std::size(dbb_periods_mm) * t.tracks->size();
  return true;
}

// Along x with period p_mm.
Variant profile_variant(const ProfileTerms& t, double p_mm) {
  Variant v =
      make_variant(t.g, {results::name(results::profile_cyclic_sin), results::name(results::profile_cyclic_cos)},
                   [p_mm](const Pt& p, double* o) {
                     o[0] = std::sin(2 * pi * p.x_mm / p_mm);
                     o[1] = std::cos(2 * pi * p.x_mm / p_mm);
                   });
  v.fixed.push_back({results::name(results::cyclic_period, "xy", 0), p_mm, nan});
  v.searched = 1;
  v.report = [](const Eigen::VectorXd& x, const Eigen::MatrixXd& cov) {
    return amp_phase(results::name(results::cyclic_error, "xy", 0), results::name(results::cyclic_phase, "xy", 0), x,
                     cov);
  };
  return v;
}

bool cyclic_error_profile_term(const ProfileTerms& t, Candidate& c) {
  for (const double p_mm : profile_periods_mm) {
    Variant v = profile_variant(t, p_mm);
    if (p_mm == profile_periods_mm[0]) v.beyond.push_back(profile_variant(t, profile_period_below_mm));
    if (p_mm == profile_periods_mm[std::size(profile_periods_mm) - 1])
      v.beyond.push_back(profile_variant(t, profile_period_above_mm));
    c.variants.push_back(std::move(v));
  }
  return true;
}

}  // namespace

extern const Effect cyclic_error{
    {"cyclic_error",
     "lead-screw or encoder pitch error repeating every lead of the screw",
     "axis position",
     "a sinusoid in axis position with the screw lead as period, the same in every run",
     {},
     {"dbb", "flatness", "straightness"}},
    {"a lead-screw (or scale) pitch error repeats every lead along the axis, at the same position in every run",
     &cyclic_error_dbb_term},
    {"a lead-screw pitch error of the X drive repeats every lead along x", &cyclic_error_profile_term}};

}  // namespace guideway::models::explain::effects
