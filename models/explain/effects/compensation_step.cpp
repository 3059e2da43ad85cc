// compensation_step: a controller's backlash compensation switched at the commanded reversal (LinuxCNC's
// COMP_FILE or BACKLASH: a per-joint table's forward and reverse columns), while the drive follows its command
// one position-loop lag tau later: the drive takes the table's step before its own reversal, turns early, and
// the carriage crosses its deadband early. Away from the reversals the step and the deadband cancel (that is
// what the table is for); at each reversal of a compensated axis a dip of about half the backlash is left,
// some tau wide, beginning before the reversal the angles show.
//
// The dip is computed, not assumed: the reversal of an axis on a circle (its command c = -r (1 - cos w t)
// about the commanded reversal at t = 0), the drive a first-order lag tau of c + (b/2) sign(dc/dt), the
// carriage behind a deadband of width b, against the drive's path without the step (what the encoders' angles
// and the base's scale already hold). One transient per run, lag and width, looked up per sample by its time
// from the commanded reversal: on the encoders' angles (a live session's) that is tau before the reversal the
// angles show, on commanded angles it is that reversal.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <utility>

#include <Eigen/LU>
#include <Eigen/QR>

#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

constexpr double lags_ms[] = {10.0, 20.0, 30.0, 50.0, 80.0};
// A step past each end of the lags (Variant::beyond): a stiffer position loop (5 ms; at no lag the drive would take the
// table's step exactly at the reversal, and no dip is left: 0 is no step past) or a slower one (120 ms) is as physical.
constexpr double lag_below_ms = 5.0, lag_above_ms = 120.0;
constexpr double before_lags = 4.0, after_lags = 8.0;  // the transient's extent about the commanded reversal
constexpr int steps_per_lag = 100;

// The carriage's error along the axis (m) after a reversal from + to -, against the lagged command without the
// table's step, every tau / steps_per_lag from -before_lags tau to +after_lags tau about the commanded reversal.
struct Transient {
  double tau = 0;
  std::vector<double> error_m;
  [[nodiscard]] double at(double t_s) const {
    const double k = (t_s / tau + before_lags) * steps_per_lag;
    if (k <= 0 || k >= static_cast<double>(error_m.size() - 1)) return 0.0;
    const auto i = static_cast<std::size_t>(k);
    const double f = k - static_cast<double>(i);
    return error_m[i] + f * (error_m[i + 1] - error_m[i]);
  }
};

Transient reversal_transient(double radius_m, double omega, double tau, double b_m) {
  Transient tr;
  tr.tau = tau;
  const double dt = tau / steps_per_lag;
  const auto n = static_cast<std::size_t>((before_lags + after_lags) * steps_per_lag) + 1;
  // Well before the reversal the command climbs at a steady rate: the lags are on their ramp response.
  const double t0 = -before_lags * tau - 5.0 * tau;
  const auto command = [&](double t) { return -radius_m * (1.0 - std::cos(omega * t)); };
  const auto rate = [&](double t) { return -radius_m * omega * std::sin(omega * t); };
  double with_step = command(t0) + 0.5 * b_m - tau * rate(t0);
  double without = command(t0) - tau * rate(t0);
  double carriage = with_step - 0.5 * b_m;
  const double decay = std::exp(-dt / tau);
  tr.error_m.reserve(n);
  for (double t = t0; tr.error_m.size() < n; t += dt) {
    // The exact response of a first-order lag to the command's ramp over the step.
    const auto lag = [&](double y, double u0, double u1) {
      const double m = (u1 - u0) / dt;
      return u1 - tau * m + (y - u0 + tau * m) * decay;
    };
    const double step0 = t < 0 ? 0.5 * b_m : -0.5 * b_m, step1 = t + dt < 0 ? 0.5 * b_m : -0.5 * b_m;
    with_step = lag(with_step, command(t) + step0, command(t + dt) + step1);
    without = lag(without, command(t), command(t + dt));
    const double half = 0.5 * b_m;
    if (with_step - carriage > half) carriage = with_step - half;
    if (with_step - carriage < -half) carriage = with_step + half;
    if (t + dt >= -before_lags * tau - 0.5 * dt) tr.error_m.push_back(carriage - without);
  }
  return tr;
}

// What the term needs of a sample (an array of its own: the generator runs in every fold).
struct StepSample {
  double lambda, c, s, zeta_rad, dir, omega, radius_m;
};

struct StepShapes {
  std::vector<StepSample> g;
  bool encoder_angles = false;  // every run's angles are the encoders' (the drives'): tau after the command's
  std::vector<std::string> names;
};

// For axis 0 (the plane's first: reverses at multiples of pi) or 1 (half a turn of that later): the time from
// the nearest reversal of the run's angle (negative before it) and the axis' direction before that reversal.
std::pair<double, double> from_reversal(const StepSample& p, int axis) {
  const double z = p.zeta_rad - (axis == 0 ? 0.0 : pi / 2);
  const double last = p.dir > 0 ? std::floor(z / pi) * pi : std::ceil(z / pi) * pi;
  const double since = std::abs(z - last) / p.omega;
  const double until = pi / p.omega - since;
  const double nearest = since <= until ? last : last + p.dir * pi;
  // Axis 0 follows r cos(z): before a reversal at z = k pi it moved towards cos = (-1)^k, i.e. +1 for even k.
  const auto k = static_cast<long>(std::lround(nearest / pi));
  const double before = k % 2 == 0 ? 1.0 : -1.0;
  return {since <= until ? since : -until, before};
}

Variant variant_at(const StepShapes& sh, double tau, std::array<double, 2> b_m) {
  std::map<std::array<double, 3>, Transient> cache;  // (r, omega, b) -> transient
  const auto transient = [&](const StepSample& p, double b) -> const Transient& {
    const std::array<double, 3> key{p.radius_m, p.omega, b};
    auto it = cache.find(key);
    if (it == cache.end()) it = cache.emplace(key, reversal_transient(p.radius_m, p.omega, tau, b)).first;
    return it->second;
  };
  const double shift = sh.encoder_angles ? tau : 0.0;  // the commanded reversal, before the angles' one
  Variant v;
  v.block.names = sh.names;
  v.block.columns.resize(static_cast<Eigen::Index>(sh.g.size()), 2);
  for (std::size_t i = 0; i < sh.g.size(); ++i) {
    const StepSample& p = sh.g[i];
    const auto row = static_cast<Eigen::Index>(i);
    for (int axis = 0; axis < 2; ++axis) {
      const auto [t, before] = from_reversal(p, axis);
      // Per unit of the width (the column's coefficient is the width, in the residual's unit).
      const double b = b_m[static_cast<std::size_t>(axis)];
      const double e = before * transient(p, b).at(t + shift) / b;
      v.block.columns(row, axis) = p.lambda * (axis == 0 ? p.c : p.s) * e;
    }
  }
  v.fixed.push_back(
      {results::name(results::compensation_step_lag), tau * 1e3, std::numeric_limits<double>::quiet_NaN()});
  v.searched = 1;
  return v;
}

// At lag tau_ms: the transient at a 1 um width, the widths fitted to the residual `rr` on its rows `rows`, then the
// transient at those widths, and again until they settle (the deadband makes the shape depend on them; at most four
// refits).
Variant settled_variant(const StepShapes& sh, double tau_ms, const std::vector<Eigen::Index>& rows,
                        const Eigen::VectorXd& rr) {
  // Rounded to 1 nm so that folds with almost the same widths share their transients' shape.
  const auto width = [](double um) { return um > 0.001 ? std::round(um * 1e3) * 1e-9 : 1e-6; };
  const double tau = tau_ms * 1e-3;
  std::array<double, 2> b_m{1e-6, 1e-6};
  Variant v = variant_at(sh, tau, b_m);
  for (int pass = 0; pass < 4; ++pass) {
    const Eigen::MatrixXd x = v.block.columns(rows, Eigen::all);
    const Eigen::Vector2d b = x.colPivHouseholderQr().solve(rr);
    const std::array<double, 2> next{width(b[0]), width(b[1])};
    if (next == b_m) break;
    b_m = next;
    v = variant_at(sh, tau, b_m);
  }
  return v;
}

// The residual and its mask a generator was given, kept for what it makes later.
using MadeFrom = std::pair<Eigen::VectorXd, std::vector<bool>>;

// The variant at lag tau_ms a step past the grid's end, settled on the residual as the grid's are, but made only where
// it is tried (Variant::fill): the edge is judged once per forward step, the grid's variants are made in every fold.
// It keeps the residual and its mask (9 bytes a sample) rather than settling two more lags in every call.
Variant past_variant(std::shared_ptr<const StepShapes> sh, double tau_ms, std::shared_ptr<const MadeFrom> made) {
  Variant v;
  v.block.names = sh->names;
  v.fixed.push_back({results::name(results::compensation_step_lag), tau_ms, std::numeric_limits<double>::quiet_NaN()});
  v.searched = 1;
  v.fill = [sh = std::move(sh), tau_ms, made = std::move(made)](Eigen::Ref<Eigen::MatrixXd> out) {
    const std::vector<Eigen::Index> rows = rows_in_use(made->second);
    const Eigen::VectorXd rr = made->first(rows);
    out = settled_variant(*sh, tau_ms, rows, rr).block.columns;
  };
  return v;
}

// For each lag of the grid its settled variant; those at the grid's two ends carry the variant a step past it.
std::vector<Variant> compensation_step_variants(const std::shared_ptr<const StepShapes>& sh, const Eigen::VectorXd& r,
                                                const std::vector<bool>& use) {
  std::vector<Variant> out;
  const std::vector<Eigen::Index> rows = rows_in_use(use);
  const Eigen::VectorXd rr = r(rows);
  const auto made = std::make_shared<const MadeFrom>(r, use);
  for (const double tau_ms : lags_ms) {
    Variant v = settled_variant(*sh, tau_ms, rows, rr);
    if (tau_ms == lags_ms[0]) v.beyond.push_back(past_variant(sh, lag_below_ms, made));
    if (tau_ms == lags_ms[std::size(lags_ms) - 1]) v.beyond.push_back(past_variant(sh, lag_above_ms, made));
    out.push_back(std::move(v));
  }
  return out;
}

// Whether the runs show a backlash step of their own (the ideal step, fitted with the base: more than 5 u on an
// axis): a machine whose controller compensates its backlash does not; one that shows it has no table, and a
// compensation step is not what its reversals hold (its deadband's take-up would be read as one).
bool shows_backlash(const DbbTerms& t) {
  if (!t.base || t.g.empty()) return false;
  const Eigen::Index n = static_cast<Eigen::Index>(t.g.size());
  // The base's own backlash columns (the ballbar diagnostics' base has them) are tested with the rest of it as
  // the base; else the ideal step is, with the base's span projected out (Lai's base is rank-deficient for
  // in-plane runs: only its span matters).
  const Block fitted = t.base->base();
  Eigen::MatrixXd base = fitted.columns, step(n, 2);
  std::vector<Eigen::Index> own;
  for (Eigen::Index k = 0; k < base.cols(); ++k)
    if (fitted.names[static_cast<std::size_t>(k)].starts_with("backlash_")) own.push_back(k);
  if (own.size() == 2) {
    step << base.col(own[0]), base.col(own[1]);
    Eigen::MatrixXd rest(n, base.cols() - 2);
    for (Eigen::Index k = 0, j = 0; k < base.cols(); ++k)
      if (k != own[0] && k != own[1]) rest.col(j++) = base.col(k);
    base = rest;
  } else {
    for (Eigen::Index i = 0; i < n; ++i) {
      const Geo& p = t.g[static_cast<std::size_t>(i)];
      step(i, 0) = -p.lambda * 0.5 * p.sgn_a * p.c;
      step(i, 1) = -p.lambda * 0.5 * p.sgn_b * p.s;
    }
  }
  // Away from every reversal (beyond the longest transient searched): the step stands there, the dip does not.
  std::vector<Eigen::Index> away;
  const double extent_s = after_lags * lags_ms[std::size(lags_ms) - 1] * 1e-3;
  for (Eigen::Index i = 0; i < n; ++i) {
    const Geo& g = t.g[static_cast<std::size_t>(i)];
    const StepSample p{g.lambda, g.c, g.s, g.zeta_rad, g.dir, g.omega_rad_per_s, g.radius_m};
    if (std::abs(from_reversal(p, 0).first) > extent_s && std::abs(from_reversal(p, 1).first) > extent_s)
      away.push_back(i);
  }
  if (away.size() < 100) return false;
  base = Eigen::MatrixXd(base(away, Eigen::all));
  step = Eigen::MatrixXd(step(away, Eigen::all));
  const Eigen::VectorXd y_away = t.base->y()(away);
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> bq(base);
  const auto m = static_cast<Eigen::Index>(away.size());
  const Eigen::MatrixXd q = bq.householderQ() * Eigen::MatrixXd::Identity(m, bq.rank());
  const Eigen::MatrixXd x = step - q * (q.transpose() * step);
  const Eigen::VectorXd y = y_away - q * (q.transpose() * y_away);
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> xq(x);
  if (xq.rank() < 2 || m <= bq.rank() + 2) return false;
  const Eigen::Vector2d beta = xq.solve(y);
  const double s2 = (y - x * beta).squaredNorm() / static_cast<double>(m - bq.rank() - 2);
  const Eigen::Matrix2d cov = (x.transpose() * x).inverse() * s2;
  return std::abs(beta[0]) > 5.0 * std::sqrt(cov(0, 0)) || std::abs(beta[1]) > 5.0 * std::sqrt(cov(1, 1));
}

bool compensation_step_dbb_term(const DbbTerms& t, Candidate& c) {
  if (shows_backlash(t)) return false;
  auto sh = std::make_shared<StepShapes>();
  for (const Geo& p : t.g) sh->g.push_back({p.lambda, p.c, p.s, p.zeta_rad, p.dir, p.omega_rad_per_s, p.radius_m});
  sh->encoder_angles = std::all_of(t.runs.begin(), t.runs.end(), [](const formats::DbbRun& r) {
    const auto it = r.metadata.find("angle_source");
    return it != r.metadata.end() && it->second == "encoders";
  });
  sh->names = {results::name(results::compensation_step, t.plane, 0),
               results::name(results::compensation_step, t.plane, 1)};
  c.generate = [sh = std::shared_ptr<const StepShapes>(std::move(sh))](const Eigen::VectorXd& r,
                                                                       const std::vector<bool>& use) {
    return compensation_step_variants(sh, r, use);
  };
  c.search_size = std::size(lags_ms);
  return true;
}

}  // namespace

extern const Effect compensation_step{
    {"compensation_step",
     "a controller's backlash compensation switched at the commanded reversal while the drive follows one lag "
     "later: the carriage crosses its deadband early",
     "reversal of a compensated axis",
     "a dip of about half the table's backlash at each reversal, one drive lag wide, beginning before it",
     {},
     {"dbb"}},
    {"the controller's backlash compensation taken at the commanded reversal: the drive follows its step one lag "
     "later and the carriage crosses its deadband early",
     &compensation_step_dbb_term},
    {},
    true};

}  // namespace guideway::models::explain::effects
