// cyclic_error: a lead-screw (or scale) pitch error repeating every lead along an axis.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
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

// The leads searched on a DBB circle (mm).
constexpr double dbb_periods_mm[] = {1.0,  2.0,  2.5,  3.0,  4.0,  5.0,  6.0,  8.0, 10.0,
                                     12.0, 12.5, 15.0, 16.0, 20.0, 25.0, 32.0, 40.0};

// Along plane axis `axis` with period p_mm, on the positions of drive track `track`.
Variant dbb_variant(const std::vector<Geo>& gg, const std::string& plane, int axis, double p_mm,
                    const dbb::DriveTrack& track, bool delay_searched) {
  const double k = 2 * pi / (p_mm * 1e-3);
  const std::vector<double>& pos = axis == 0 ? track.pos_a : track.pos_b;
  Variant v;
  v.block.names = {results::name(results::cyclic_sin_column, plane, axis),
                   results::name(results::cyclic_cos_column, plane, axis)};
  v.block.columns.resize(static_cast<Eigen::Index>(gg.size()), 2);
  for (std::size_t i = 0; i < gg.size(); ++i) {
    double sn = 0, cs = 0;
    dbb::fast_sincos(k * pos[i], sn, cs);
    const double proj = gg[i].lambda * (axis == 0 ? gg[i].c : gg[i].s);
    v.block.columns(static_cast<Eigen::Index>(i), 0) = proj * sn;
    v.block.columns(static_cast<Eigen::Index>(i), 1) = proj * cs;
  }
  v.fixed.push_back({results::name(results::cyclic_period, plane, axis), p_mm, nan});
  v.searched = 1;
  if (delay_searched) {
    v.fixed.push_back({results::name(results::cyclic_delay, plane, axis), track.delay_s * 1e3, nan});
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

// The delayed variants made so far, by (axis, period, delay): the generator runs in every fold of every
// held-out test and offers the same few periods again and again, and a variant's columns depend on its
// period and delay only (a sine and cosine per sample: most of the generator's time). Bounded in memory;
// beyond the bound a variant is made again when asked for.
class DelayedVariants {
 public:
  Variant get(const std::vector<Geo>& gg, const std::string& plane, int axis, std::size_t period,
              const std::vector<dbb::DriveTrack>& tracks, std::size_t track) {
    const std::size_t key =
        (static_cast<std::size_t>(axis) * std::size(dbb_periods_mm) + period) * tracks.size() + track;
    const std::lock_guard<std::mutex> lock(mutex_);
    if (const auto it = made_.find(key); it != made_.end()) return it->second;
    Variant v = dbb_variant(gg, plane, axis, dbb_periods_mm[period], tracks[track], true);
    const auto bytes = static_cast<std::size_t>(v.block.columns.size()) * sizeof(double);
    if (bytes_ + bytes <= budget_bytes) {
      bytes_ += bytes;
      made_.emplace(key, v);
    }
    return v;
  }

 private:
  static constexpr std::size_t budget_bytes = std::size_t{96} << 20;
  std::mutex mutex_;
  std::map<std::size_t, Variant> made_;
  std::size_t bytes_ = 0;
};

// Periods and delays: the two periods per axis whose undelayed terms explain most of the residual, each
// then tried at every delay.
std::vector<Variant> best_periods_at_every_delay(const std::vector<Geo>& gg, const std::string& plane,
                                                 const std::vector<dbb::DriveTrack>& tracks,
                                                 const std::vector<Variant>& undelayed, DelayedVariants& delayed,
                                                 const Eigen::VectorXd& r, const std::vector<bool>& use) {
  const std::vector<Eigen::Index> rows = rows_in_use(use);
  std::vector<Variant> vs;
  const std::size_t per_axis = std::size(dbb_periods_mm);
  for (int axis = 0; axis < 2; ++axis) {
    std::vector<std::pair<double, std::size_t>> score;  // (-explained, period's index)
    for (std::size_t k = 0; k < per_axis; ++k) {
      // The 2 x 2 normal equations summed over the rows in use in place (the rows' copy of the columns was
      // most of the generator's time at large n).
      const Eigen::MatrixXd& x = undelayed[static_cast<std::size_t>(axis) * per_axis + k].block.columns;
      Eigen::Matrix2d xtx = Eigen::Matrix2d::Zero();
      Eigen::Vector2d xtr = Eigen::Vector2d::Zero();
      for (const Eigen::Index i : rows) {
        const double s = x(i, 0), c = x(i, 1), ri = r[i];
        xtx(0, 0) += s * s;
        xtx(0, 1) += s * c;
        xtx(1, 1) += c * c;
        xtr[0] += s * ri;
        xtr[1] += c * ri;
      }
      xtx(1, 0) = xtx(0, 1);
      score.emplace_back(-xtr.dot(xtx.ldlt().solve(xtr)), k);
    }
    std::sort(score.begin(), score.end());
    for (std::size_t k = 0; k < 2 && k < score.size(); ++k)
      for (std::size_t track = 0; track < tracks.size(); ++track)
        vs.push_back(delayed.get(gg, plane, axis, score[k].second, tracks, track));
  }
  return vs;
}

bool cyclic_error_dbb_term(const DbbTerms& t, Candidate& c) {
  std::vector<Variant> undelayed;  // the command's positions (the drives' when read from the encoders)
  for (int axis = 0; axis < 2; ++axis)
    for (double p_mm : dbb_periods_mm)
      undelayed.push_back(dbb_variant(t.g, t.plane, axis, p_mm, t.tracks->front(), false));
  if (t.tracks->size() == 1) {
    c.variants = std::move(undelayed);
    return true;
  }
  const auto geo = std::make_shared<const std::vector<Geo>>(t.g);
  const auto base = std::make_shared<const std::vector<Variant>>(std::move(undelayed));
  const auto delayed = std::make_shared<DelayedVariants>();
  c.generate = [geo, plane = t.plane, tracks = t.tracks, base, delayed](const Eigen::VectorXd& r,
                                                                        const std::vector<bool>& use) {
    return best_periods_at_every_delay(*geo, plane, *tracks, *base, *delayed, r, use);
  };
  c.search_size = 2 * std::size(dbb_periods_mm) * t.tracks->size();
  return true;
}

bool cyclic_error_profile_term(const ProfileTerms& t, Candidate& c) {
  for (double p_mm : {1.0, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0}) {
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
