#include "models/explain/dbb_explain.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <functional>
#include <memory>
#include <numbers>
#include <span>
#include <stdexcept>

#include <Eigen/QR>
#include <unsupported/Eigen/FFT>

#include "core/number_format.hpp"
#include "models/common/least_squares.hpp"
#include "models/dbb/fast_sincos.hpp"
#include "models/dbb/geometry.hpp"
#include "models/dbb/identify.hpp"

namespace guideway::models::explain {

namespace {

constexpr double pi = std::numbers::pi;

// Per-sample geometry and what EXPLAIN's effects add to it.
struct Geo : dbb::SampleGeometry {
  double center_a_m = 0, center_b_m = 0;  // the circle's centre, where a lagging drive's position is reckoned from
  double t_s = 0;  // machine time since the earliest run's start (or run time when not all runs have start_time_s)
};

// Sums of w^2, w^2 t and w^2 t^2 over a run's samples (w a projection on the bar, t in s).
struct Moments {
  double w2 = 0, w2t = 0, w2t2 = 0;
};

bool all_have_start_time(const std::vector<formats::DbbRun>& runs) {
  return std::all_of(runs.begin(), runs.end(), [](const formats::DbbRun& r) { return r.metadata.count("start_time_s") > 0; });
}

double start_time_of(const formats::DbbRun& r) {
  const std::string& s = r.metadata.at("start_time_s");
  try {
    std::size_t used = 0;
    const double v = std::stod(s, &used);
    if (used != s.size() || !std::isfinite(v)) throw std::invalid_argument(s);
    return v;
  } catch (const std::exception&) {
    throw formats::DbbRunFormatError(r.source + ": start_time_s: not a number: '" + s + "'");
  }
}

std::vector<Geo> geometry(const std::vector<formats::DbbRun>& runs, bool machine_time) {
  // Time counts from the earliest run's start: a Unix-epoch clock (~1.8e9 s) would make a drift
  // column nearly constant and cost a sinusoid's phase its digits.
  double origin_s = 0.0;
  if (machine_time) {
    origin_s = start_time_of(runs.front());
    for (const auto& run : runs) origin_s = std::min(origin_s, start_time_of(run));
  }
  std::vector<Geo> g;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const formats::DbbRun& run = runs[k];
    formats::validate_dbb_run(run);
    const double t0 = machine_time ? start_time_of(run) - origin_s : 0.0;
    for (std::size_t i = 0; i < run.angle_rad.size(); ++i) {
      Geo p;
      dbb::fill_sample_geometry(run, k, i, p);
      p.center_a_m = run.center_a_m;
      p.center_b_m = run.center_b_m;
      p.t_s = t0 + run.t_s[i];
      g.push_back(p);
    }
  }
  return g;
}

// Lai's geometric terms: the first 17 characteristic functions (backlash and servo mismatch are
// candidates here, not base), in um per reported unit.
constexpr double lai_si_per_reported[] = {1e-6, 1e-6, 1.0, 1.0, 1.0, 1e3, 1e6, 1e3, 1e6,
                                          1.0,  1e3,  1e6, 1e3, 1e6, 1.0, 1e3, 1e6};
constexpr std::size_t lai_geometric = std::size(lai_si_per_reported);

Block lai_base(const std::vector<Geo>& g) {
  Block b;
  const auto names = dbb::lai3_parameter_names();
  b.names.assign(names.begin(), names.begin() + lai_geometric);
  b.columns.resize(static_cast<Eigen::Index>(g.size()), static_cast<Eigen::Index>(lai_geometric));
  for (std::size_t i = 0; i < g.size(); ++i) {
    const auto ch = dbb::lai3_characteristics(g[i].radius_m, g[i].height_m, static_cast<int>(g[i].dir),
                                              g[i].feed_m_per_s, g[i].zeta_rad);
    for (std::size_t k = 0; k < lai_geometric; ++k)
      b.columns(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) = ch[k] * lai_si_per_reported[k] * 1e6;
  }
  return b;
}


// The delays (s) by which the drives may follow the commanded angle of the runs, for the terms that live
// on the drives' positions (backlash, cyclic error): none when every run's angles were read from the axis
// encoders (metadata angle_source = encoders, as a live session writes), else a grid up to a slow position
// loop's 1/Kv (commanded angles, or angles from time and feed as a ballbar's software computes them).
std::vector<double> drive_delays_s(const std::vector<formats::DbbRun>& runs) {
  const bool encoders = std::all_of(runs.begin(), runs.end(), [](const formats::DbbRun& r) {
    const auto it = r.metadata.find("angle_source");
    return it != r.metadata.end() && it->second == "encoders";
  });
  if (encoders) return {0.0};
  return {0.0, 5e-3, 10e-3, 15e-3, 20e-3, 25e-3, 30e-3, 40e-3, 50e-3, 60e-3, 80e-3, 100e-3};
}

// The drives' motion on the circle when they follow the command `delay_s` late, per sample: their
// positions, the signs of their velocities and how far each has moved from its last extreme (the last
// reversal). Computed once per problem for every delay searched (the backlash and cyclic terms live on
// the drives' positions, and their generators run many times).
struct DriveTrack {
  double delay_s = 0;
  std::vector<double> pos_a, pos_b;    // m
  std::vector<double> vel_a, vel_b;    // sign of the velocity, -1 / 0 / +1
  std::vector<double> rise_a, rise_b;  // r (1 - cos phi), phi the angle past the axis's last reversal (m)
};
std::shared_ptr<const std::vector<DriveTrack>> drive_tracks(const std::vector<Geo>& g, const std::vector<double>& delays) {
  auto out = std::make_shared<std::vector<DriveTrack>>();
  for (const double d : delays) {
    DriveTrack t;
    t.delay_s = d;
    for (const Geo& p : g) {
      const double z = p.zeta_rad - p.dir * p.omega_rad_per_s * d;
      double s = 0, c = 0;
      dbb::fast_sincos(z, s, c);
      const auto rise = [&](double phase) {
        return dbb::rise_since_reversal_m(p.radius_m, dbb::angle_since_reversal_rad(z, phase, p.dir));
      };
      t.pos_a.push_back(p.center_a_m + p.radius_m * c);
      t.pos_b.push_back(p.center_b_m + p.radius_m * s);
      t.vel_a.push_back(dbb::velocity_sign_a(p.dir, s));
      t.vel_b.push_back(dbb::velocity_sign_b(p.dir, c));
      t.rise_a.push_back(rise(0.0));
      t.rise_b.push_back(rise(pi / 2));
    }
    out->push_back(std::move(t));
  }
  return out;
}

// Lost motion per unit backlash of a deadband of width b_a / b_b (m) along each axis ({a, b}) at
// sample i of the track.
std::array<double, 2> lost_motion(const DriveTrack& t, std::size_t i, double b_a, double b_b) {
  return {dbb::deadband_lost_motion(t.vel_a[i], t.rise_a[i], b_a),
          dbb::deadband_lost_motion(t.vel_b[i], t.rise_b[i], b_b)};
}

// servo_lag's block: the base's prediction seen where the drives were, lag behind the command,
// -dir omega dy/dzeta per ms of lag (the reading at the drive's angle zeta - dir omega lag, to first
// order). The base is refitted to the rows in use, so a held-out row's y does not reach the column.
std::function<std::vector<Variant>(const Eigen::VectorXd&, const std::vector<bool>&)> servo_lag_generator(
    const Block& base, const Eigen::VectorXd& y_um, std::shared_ptr<const std::vector<Geo>> geo) {
  auto data = std::make_shared<const std::pair<Block, Eigen::VectorXd>>(base, y_um);
  return [data, geo](const Eigen::VectorXd&, const std::vector<bool>& use) {
    const auto& [b, y] = *data;
    const auto& gg = *geo;
    const Eigen::VectorXd predicted = base_prediction(b, y, use);
    if (predicted.size() == 0) return std::vector<Variant>{};
    Variant v;
    v.block.names = {"servo_lag_ms"};
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
    return std::vector<Variant>{v};
  };
}

// `reading_um`: the reading the model predicts per sample (the sensor's operating point; taking the
// measured value would let the candidate fit the very effects in it).
std::vector<Candidate> dbb_candidates(const std::vector<Geo>& g, const std::vector<formats::DbbRun>& runs, bool machine_time,
                                      const std::vector<double>& reading_um) {
  const auto tracks = drive_tracks(g, drive_delays_s(runs));
  const std::string A = dbb::axis_letter(runs.front().plane, 0), B = dbb::axis_letter(runs.front().plane, 1);
  std::vector<Candidate> out;
  {
    Candidate c{"servo_mismatch",
                "the two axes' position loops lag by different times, so the circle is stretched along a diagonal by "
                "an amount that grows with feed and flips with direction",
                {}, {}, 0};
    c.variants.push_back(make_variant(g, {"servo_mismatch_ms"}, [](const Geo& p, double* o) {
      o[0] = p.lambda * p.dir * p.feed_m_per_s * p.s * p.c * 1e3;  // 1 ms of lag difference; v in m/s -> um
    }));
    out.push_back(std::move(c));
  }
  {
    Candidate c{"backlash",
                "lost motion in the drives: at each reversal an axis stays behind the command by half its play",
                {}, {}, 0};
    const std::vector<std::string> names{"backlash_" + A + "_um", "backlash_" + B + "_um"};
    // Ideal step first (actual a = commanded a - (b/2) sign(da/dt)); then, from the current residual,
    // the deadband response at the width the step suggests (the step alone biases it and leaves an
    // inward spike at every reversal that another candidate would otherwise claim), the width refined
    // once by a fit of that response, for each drive delay of the grid.
    const auto geo = std::make_shared<const std::vector<Geo>>(g);
    c.generate = [geo, names, tracks](const Eigen::VectorXd& r, const std::vector<bool>& use) {
      const auto& gg = *geo;
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
      const auto response = [&](std::array<double, 2> b, const DriveTrack& t) {
        Variant v;
        v.block.names = names;
        v.block.columns.resize(static_cast<Eigen::Index>(gg.size()), 2);
        for (std::size_t i = 0; i < gg.size(); ++i) {
          const auto m = lost_motion(t, i, b[0], b[1]);
          v.block.columns(static_cast<Eigen::Index>(i), 0) = gg[i].lambda * m[0] * gg[i].c;
          v.block.columns(static_cast<Eigen::Index>(i), 1) = gg[i].lambda * m[1] * gg[i].s;
        }
        if (tracks->size() > 1) {
          v.fixed.push_back({"backlash_delay_ms", t.delay_s * 1e3, std::numeric_limits<double>::quiet_NaN()});
          v.searched = 1;
        }
        return v;
      };
      const auto step = sizes(vs.front());
      if (step[0] > 0 || step[1] > 0) {
        for (const DriveTrack& t : *tracks) {
          // The width the step suggests, then once more from a fit of the response at that width.
          Variant first = response(step, t);
          const auto refined = sizes(first);
          vs.push_back(refined[0] > 0 || refined[1] > 0 ? response(refined, t) : std::move(first));
        }
      }
      return vs;
    };
    c.search_size = 1 + tracks->size();
    out.push_back(std::move(c));
  }
  {
    Candidate c{"reversal_spike",
                "stiction at the axis reversals: the axis sticks and the servo catches up with a short decay",
                {}, {}, 0};
    for (double tau_ms : {2.0, 5.0, 10.0, 20.0, 50.0, 100.0}) {
      const double tau = tau_ms * 1e-3;
      Variant v = make_variant(g, {"reversal_spike_" + A + "_um", "reversal_spike_" + B + "_um"},
                               [tau](const Geo& p, double* o) {
                                 o[0] = p.lambda * p.c * (-p.sgn_a) * dbb::reversal_spike_decay(p.since_a_s, tau);
                                 o[1] = p.lambda * p.s * (-p.sgn_b) * dbb::reversal_spike_decay(p.since_b_s, tau);
                               });
      v.fixed.push_back({"reversal_spike_decay_ms", tau_ms, std::numeric_limits<double>::quiet_NaN()});
      v.searched = 1;
      c.variants.push_back(std::move(v));
    }
    out.push_back(std::move(c));
  }
  {
    Candidate c{"lateral_play",
                "the carriages shift sideways in their guideways when their direction of travel changes", {}, {}, 0};
    c.variants.push_back(
        make_variant(g, {"lateral_play_" + A + "_um", "lateral_play_" + B + "_um"}, [](const Geo& p, double* o) {
          o[0] = p.lambda * 0.5 * p.sgn_a * p.s;
          o[1] = p.lambda * 0.5 * p.sgn_b * p.c;
        }));
    out.push_back(std::move(c));
  }
  {
    Candidate c{"cyclic_error",
                "a lead-screw (or scale) pitch error repeats every lead along the axis, at the same position in every run",
                {}, {}, 0};
    static constexpr double periods_mm[] = {1.0,  2.0,  2.5,  3.0,  4.0,  5.0,  6.0,  8.0, 10.0,
                                            12.0, 12.5, 15.0, 16.0, 20.0, 25.0, 32.0, 40.0};
    // Along axis `axis` with period p_mm, on the positions of drive track t.
    const auto cyclic = [A, B](const std::vector<Geo>& gg, int axis, double p_mm, const DriveTrack& t, bool delay_searched) {
      const std::string L = axis == 0 ? A : B;
      const double k = 2 * pi / (p_mm * 1e-3);
      const std::vector<double>& pos = axis == 0 ? t.pos_a : t.pos_b;
      Variant v;
      v.block.names = {"cyclic_sin_" + L, "cyclic_cos_" + L};
      v.block.columns.resize(static_cast<Eigen::Index>(gg.size()), 2);
      for (std::size_t i = 0; i < gg.size(); ++i) {
        double sn = 0, cs = 0;
        dbb::fast_sincos(k * pos[i], sn, cs);
        const double proj = gg[i].lambda * (axis == 0 ? gg[i].c : gg[i].s);
        v.block.columns(static_cast<Eigen::Index>(i), 0) = proj * sn;
        v.block.columns(static_cast<Eigen::Index>(i), 1) = proj * cs;
      }
      v.fixed.push_back({"cyclic_period_" + L + "_mm", p_mm, std::numeric_limits<double>::quiet_NaN()});
      v.searched = 1;
      if (delay_searched) {
        v.fixed.push_back({"cyclic_delay_" + L + "_ms", t.delay_s * 1e3, std::numeric_limits<double>::quiet_NaN()});
        v.searched = 2;
      }
      v.group = L;
      v.report = [L](const Eigen::VectorXd& x, const Eigen::MatrixXd& cov) {
        return amp_phase("cyclic_error_" + L + "_um", "cyclic_phase_" + L + "_deg", x, cov);
      };
      return v;
    };
    std::vector<Variant> undelayed;  // the command's positions (the drives' when read from the encoders)
    for (int axis = 0; axis < 2; ++axis)
      for (double p_mm : periods_mm) undelayed.push_back(cyclic(g, axis, p_mm, tracks->front(), false));
    if (tracks->size() == 1) {
      c.variants = std::move(undelayed);
    } else {
      // Periods and delays: the two periods per axis whose undelayed terms explain most of the residual,
      // each then tried at every delay.
      const auto geo = std::make_shared<const std::vector<Geo>>(g);
      const auto base = std::make_shared<const std::vector<Variant>>(std::move(undelayed));
      c.generate = [geo, cyclic, tracks, base](const Eigen::VectorXd& r, const std::vector<bool>& use) {
        const std::vector<Eigen::Index> rows = rows_in_use(use);
        const Eigen::VectorXd rr = r(rows);
        std::vector<Variant> vs;
        const std::size_t per_axis = std::size(periods_mm);
        for (int axis = 0; axis < 2; ++axis) {
          std::vector<std::pair<double, double>> score;  // (-explained, period)
          for (std::size_t k = 0; k < per_axis; ++k) {
            const Eigen::MatrixXd x = (*base)[static_cast<std::size_t>(axis) * per_axis + k].block.columns(rows, Eigen::all);
            const Eigen::Matrix2d xtx = x.transpose() * x;
            const Eigen::Vector2d xtr = x.transpose() * rr;
            score.emplace_back(-xtr.dot(xtx.ldlt().solve(xtr)), periods_mm[k]);
          }
          std::sort(score.begin(), score.end());
          for (std::size_t k = 0; k < 2 && k < score.size(); ++k)
            for (const DriveTrack& t : *tracks) vs.push_back(cyclic(*geo, axis, score[k].second, t, true));
        }
        return vs;
      };
      c.search_size = 2 * std::size(periods_mm) * tracks->size();
    }
    out.push_back(std::move(c));
  }
  {
    Candidate c{"thermal_drift",
                "the machine or the bar grows as it warms up, a trend in time that the geometric terms only partly absorb",
                {}, {}, 0};
    const std::size_t nr = runs.size();
    // Without a common time axis each run after the first gets its own offset, in the drift's own
    // direction(s): the bar's reading, or the circle's centre along an axis (a projection on the bar).
    const std::size_t offsets = machine_time ? 0 : nr - 1;
    // Directions: 0 the bar; 1 axis A, 2 axis B; 3 the centre in the plane (A and B, each its own rate).
    for (int which = 0; which < 4; ++which) {
      std::vector<int> axes;  // 0 bar, 1 A, 2 B
      if (which == 3) axes = {1, 2};
      else axes = {which};
      std::vector<std::string> names;
      for (int a : axes) names.push_back(a == 0 ? "bar_drift_um_per_min" : "drift_" + (a == 1 ? A : B) + "_um_per_min");
      for (int a : axes)
        for (std::size_t k = 1; k <= offsets; ++k)
          names.push_back((a == 0 ? std::string("bar_drift") : "drift_" + (a == 1 ? A : B)) + "_offset_run" +
                          std::to_string(k + 1) + "_um");
      Variant v = make_variant(g, names, [=](const Geo& p, double* o) {
        for (std::size_t j = 0; j < axes.size(); ++j) {
          const int a = axes[j];
          const double proj = a == 0 ? 1.0 : p.lambda * (a == 1 ? p.c : p.s);
          o[j] = proj * p.t_s / 60.0;
          if (offsets && p.run >= 1) o[axes.size() + j * offsets + p.run - 1] = proj;
        }
      });
      v.group = which == 0 ? "bar" : "centre";
      c.variants.push_back(std::move(v));
    }
    out.push_back(std::move(c));
  }
  {
    // Vibration: the strongest lines of the residual's periodogram in time, along each axis.
    Candidate c{"vibration", "a structural or drive vibration at a fixed frequency, a sinusoid in time unrelated to the position",
                {}, {}, 0};
    // The typical sample interval is the median step: live timestamps jitter, and the smallest step
    // of a real recording can be microseconds, which would put the Nyquist limit absurdly high.
    double t_span = 0, dt = 1e300;
    std::vector<double> steps;
    for (std::size_t i = 1; i < g.size(); ++i)
      if (g[i].run == g[i - 1].run && g[i].t_s > g[i - 1].t_s) steps.push_back(g[i].t_s - g[i - 1].t_s);
    if (!steps.empty()) {
      std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
      dt = steps[steps.size() / 2];
    }
    for (const auto& r : runs) t_span = std::max(t_span, r.t_s.back() - r.t_s.front());
    if (dt < 1e300 && t_span > 0) {
      // The periodogram by FFT: each run's weighted residual binned on a uniform grid of step dt (live
      // time stamps jitter; the bins only choose the candidate lines, fitted on the exact times) and
      // zero-padded to m >= 4 t_span / dt points (a power of two, at most 2^20), so the grid q / (m dt)
      // oversamples the Fourier resolution 1/t_span about 4x; each line is then placed between grid
      // points on the exact periodogram.
      std::size_t fft_size = 1;
      while (static_cast<double>(fft_size) < 4.0 * t_span / dt + 1 && fft_size < (std::size_t{1} << 20)) fft_size *= 2;
      const double df = 1.0 / (static_cast<double>(fft_size) * dt);
      const double f_lo = 4.0 / t_span, f_hi = 0.4 / dt;
      const auto q_lo = static_cast<std::size_t>(std::ceil(f_lo / df));
      const auto q_hi = std::min(static_cast<std::size_t>(std::floor(f_hi / df)), fft_size / 2 - 1);
      const std::size_t grid = q_hi >= q_lo ? q_hi - q_lo + 1 : 0;
      c.search_size = 3 * grid;
      auto geo = std::make_shared<const std::vector<Geo>>(g);
      // Held-out rows have residual 0: the periodogram is that of the rows in use.
      // Without a common clock a line keeps its frequency and amplitude from run to run but not its
      // phase: each run gets its own sine and cosine (the periodogram already sums runs' powers).
      const std::size_t phases = machine_time ? 1 : runs.size();
      // Two lines closer than the Fourier resolution 1/t_span are one line: the second strongest is
      // sought at least that far from the first.
      const auto apart = static_cast<std::size_t>(std::ceil(1.0 / (t_span * df) - 1e-9));
      // Time moments of the squared projection per direction and run, for a line's report: the
      // frequency's uncertainty (Cramer-Rao, from the spread of t about each run's centroid: the
      // periodogram that chose it sums runs' powers, so it knows f from within runs only) and, per
      // phase group, the part of it that reaches a phase counted from t = 0.
      std::array<std::vector<Moments>, 3> moments;
      for (int which = 0; which < 3; ++which) {
        auto& mom = moments[static_cast<std::size_t>(which)];
        mom.resize(runs.size());
        for (const Geo& p : g) {
          const double w = which == 0 ? 1.0 : p.lambda * (which == 1 ? p.c : p.s);
          Moments& mo = mom[p.run];
          mo.w2 += w * w;
          mo.w2t += w * w * p.t_s;
          mo.w2t2 += w * w * p.t_s * p.t_s;
        }
      }
      c.generate = [geo, fft_size, dt, df, q_lo, grid, apart, A, B, phases, moments](const Eigen::VectorXd& r,
                                                                             const std::vector<bool>&) {
        const auto& gg = *geo;
        // One periodogram per direction the vibration may have (the bar, axis A, axis B), each of the
        // residual weighted by that direction's projection on the bar: a vibration of axis A at f reads
        // as lam cos(zeta) sin(2 pi f t), whose plain periodogram peaks at f +- the circling frequency,
        // not at f. Power summed over runs: sum over runs of |sum_i w_i r_i exp(-2 pi i f t_i)|^2.
        const auto weight = [&](const Geo& p, int which) {
          return which == 0 ? 1.0 : p.lambda * (which == 1 ? p.c : p.s);
        };
        std::array<std::vector<double>, 3> pw;
        for (auto& v : pw) v.assign(grid, 0.0);
        Eigen::FFT<double> fft;
        std::vector<double> binned(fft_size);
        std::vector<std::complex<double>> spectrum;
        for (std::size_t i = 0; i < gg.size();) {
          const std::size_t first = i;
          while (i < gg.size() && gg[i].run == gg[first].run) ++i;
          for (int which = 0; which < 3; ++which) {
            std::fill(binned.begin(), binned.end(), 0.0);
            for (std::size_t j = first; j < i; ++j) {
              const auto bin = static_cast<std::size_t>(std::max(0.0, std::round((gg[j].t_s - gg[first].t_s) / dt)));
              if (bin < fft_size) binned[bin] += weight(gg[j], which) * r[static_cast<Eigen::Index>(j)];
            }
            fft.fwd(spectrum, binned);
            auto& acc = pw[static_cast<std::size_t>(which)];
            for (std::size_t q = 0; q < grid; ++q) acc[q] += std::norm(spectrum[q_lo + q]);
          }
        }
        // The exact periodogram at f (direction `which`).
        const auto power = [&](double f, int which) {
          double total = 0, re = 0, im = 0;
          for (std::size_t j = 0; j < gg.size(); ++j) {
            if (j > 0 && gg[j].run != gg[j - 1].run) {
              total += re * re + im * im;
              re = im = 0;
            }
            const double v = weight(gg[j], which) * r[static_cast<Eigen::Index>(j)];
            if (v == 0.0) continue;
            double sn = 0, cs = 0;
            dbb::fast_sincos(2 * pi * f * gg[j].t_s, sn, cs);
            re += v * cs;
            im -= v * sn;
          }
          return total + re * re + im * im;
        };
        std::vector<Variant> vs;
        for (int which = 0; which < 3; ++which) {
          const auto& at = pw[static_cast<std::size_t>(which)];
          // The strongest grid point, then the strongest at least `apart` from it.
          std::vector<std::size_t> lines;
          for (int pass = 0; pass < 2; ++pass) {
            std::size_t best = grid;
            for (std::size_t q = 0; q < grid; ++q) {
              if (!lines.empty() && (q > lines[0] ? q - lines[0] : lines[0] - q) < apart) continue;
              if (best == grid || at[q] > at[best]) best = q;
            }
            if (best < grid) lines.push_back(best);
          }
          for (const std::size_t q : lines) {
            // Between grid points on the exact periodogram: five points half a grid step apart around
            // the peak, then the parabola through the highest and its neighbours (a coherent fit over
            // runs a minute apart loses much of a line that is a fraction of a grid step off).
            const double f0 = df * static_cast<double>(q_lo + q), h = 0.5 * df;
            std::array<double, 5> pk{};
            for (int k = 0; k < 5; ++k) pk[static_cast<std::size_t>(k)] = power(f0 + (k - 2) * h, which);
            const auto top = static_cast<std::size_t>(std::max_element(pk.begin(), pk.end()) - pk.begin());
            double offset = 0.0;
            if (top > 0 && top < 4) {
              const double curvature = pk[top - 1] - 2 * pk[top] + pk[top + 1];
              if (curvature < 0) offset = std::clamp(0.5 * (pk[top - 1] - pk[top + 1]) / curvature, -0.5, 0.5);
            }
            const double f = f0 + (static_cast<double>(top) - 2.0 + offset) * h;
            const std::vector<Moments>& mom = moments[static_cast<std::size_t>(which)];
            const std::string L = which == 0 ? "bar" : (which == 1 ? A : B);
            std::vector<std::string> names;
            for (std::size_t run_k = 0; run_k < phases; ++run_k) {
              const std::string run = phases > 1 ? "_run" + std::to_string(run_k + 1) : "";
              names.push_back("vibration_sin" + run);
              names.push_back("vibration_cos" + run);
            }
            Variant v = make_variant(gg, names, [=](const Geo& p, double* o) {
              const double proj = which == 0 ? 1.0 : p.lambda * (which == 1 ? p.c : p.s);
              const std::size_t col = phases > 1 ? 2 * p.run : 0;
              double sn = 0, cs = 0;
              dbb::fast_sincos(2 * pi * f * p.t_s, sn, cs);
              o[col] = proj * sn;
              o[col + 1] = proj * cs;
            });
            v.searched = 1;
            v.group = L;
            v.report = [L, phases, f, mom](const Eigen::VectorXd& x, const Eigen::MatrixXd& cov) {
              const std::string amp = "vibration_" + L + "_um", phase = "vibration_phase_" + L + "_deg";
              // Per group: amplitude and phase with the frequency held; then u(f) from the Fisher
              // information of all groups, sigma^2 read back from the sine coefficient's variance
              // (about 2 sigma^2 / sum w^2), and each phase's u widened by 2 pi t_centroid u(f).
              std::vector<std::vector<ParamValue>> ap(phases);
              std::vector<Moments> group(phases);  // a phase group's moments: its runs' summed
              for (std::size_t run = 0; run < mom.size(); ++run) {
                Moments& m = group[phases > 1 ? run : 0];
                m.w2 += mom[run].w2;
                m.w2t += mom[run].w2t;
                m.w2t2 += mom[run].w2t2;
              }
              double info = 0.0, sigma2 = 0.0;
              for (std::size_t k = 0; k < phases; ++k) {
                const auto j = static_cast<Eigen::Index>(2 * k);
                ap[k] = amp_phase(amp, phases > 1 ? phase + "_run" + std::to_string(k + 1) : phase, x.segment(j, 2),
                                  cov.block(j, j, 2, 2));
                sigma2 += 0.25 * (cov(j, j) + cov(j + 1, j + 1)) * group[k].w2 / static_cast<double>(phases);
              }
              for (std::size_t run = 0; run < mom.size(); ++run) {
                const Moments& m = mom[run];
                const double spread = m.w2 > 0 ? m.w2t2 - m.w2t * m.w2t / m.w2 : 0.0;
                const double a = ap[phases > 1 ? run : 0][0].value;
                info += 2 * pi * pi * a * a * spread;
              }
              const double u_f = sigma2 > 0 && info > 0 ? std::sqrt(sigma2 / info) : std::numeric_limits<double>::quiet_NaN();
              std::vector<ParamValue> values;
              if (phases == 1) {
                values.push_back(ap[0][0]);
              } else {
                // One amplitude: the runs' weighted by their inverse variances.
                double sw = 0, swa = 0;
                for (const auto& a : ap)
                  if (a[0].u > 0) {
                    sw += 1 / (a[0].u * a[0].u);
                    swa += a[0].value / (a[0].u * a[0].u);
                  }
                values.push_back({amp, sw > 0 ? swa / sw : ap[0][0].value, sw > 0 ? 1 / std::sqrt(sw) : std::numeric_limits<double>::quiet_NaN()});
              }
              for (std::size_t k = 0; k < phases; ++k) {
                ParamValue ph = ap[k][1];
                const double centroid = group[k].w2 > 0 ? group[k].w2t / group[k].w2 : 0.0;
                const double from_f = 360.0 * centroid * u_f;  // deg
                ph.u = std::sqrt(ph.u * ph.u + from_f * from_f);
                values.push_back(ph);
              }
              values.push_back({"vibration_hz", f, u_f});
              return values;
            };
            vs.push_back(std::move(v));
          }
        }
        return vs;
      };
    }
    out.push_back(std::move(c));
  }
  {
    // Stick-slip: a decaying oscillation of the axis after it reverses (low speed near the reversal),
    // starting against the new direction of motion as the reversal spike does.
    Candidate c{"stick_slip",
                "friction at low speed makes an axis move in jerks just after it reverses, a decaying oscillation",
                {}, {}, 0};
    for (double f_hz : {5.0, 10.0, 20.0}) {
      for (double tau_ms : {50.0, 200.0}) {
        const double tau = tau_ms * 1e-3;
        Variant v =
            make_variant(g, {"stick_slip_" + A + "_um", "stick_slip_" + B + "_um"}, [=](const Geo& p, double* o) {
              o[0] = p.lambda * p.c * (-p.sgn_a) * dbb::reversal_spike_decay(p.since_a_s, tau) *
                     std::sin(2 * pi * f_hz * p.since_a_s);
              o[1] = p.lambda * p.s * (-p.sgn_b) * dbb::reversal_spike_decay(p.since_b_s, tau) *
                     std::sin(2 * pi * f_hz * p.since_b_s);
            });
        v.fixed.push_back({"stick_slip_hz", f_hz, std::numeric_limits<double>::quiet_NaN()});
        v.fixed.push_back({"stick_slip_decay_ms", tau_ms, std::numeric_limits<double>::quiet_NaN()});
        v.searched = 2;
        c.variants.push_back(std::move(v));
      }
    }
    out.push_back(std::move(c));
  }
  {
    Candidate c{"sensor_nonlinearity",
                "the bar's transducer is not linear over its range, an error that is a polynomial in the reading itself",
                {}, {}, 0};
    c.variants.push_back(sensor_nonlinearity_variant(reading_um));
    out.push_back(std::move(c));
  }
  return out;
}

std::vector<RunInfo> run_infos(const std::vector<formats::DbbRun>& runs) {
  std::vector<RunInfo> out;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const auto& r = runs[k];
    RunInfo ri;
    ri.label = "run" + std::to_string(k + 1) + " (" + (r.dir() > 0 ? "ccw" : "cw") + ")";
    ri.direction = r.dir();
    ri.feed_mm_per_min = std::round(r.feed_m_per_s * 60000.0 * 1e6) / 1e6;
    ri.geometry = printf_number("r%.6g", r.radius_m * 1e3) + printf_number("h%.6g", r.height_m * 1e3) + r.plane;
    out.push_back(ri);
  }
  return out;
}

void check_runs(const std::vector<formats::DbbRun>& runs) {
  if (runs.empty()) throw std::invalid_argument("explain: no runs");
  for (const auto& r : runs)
    if (r.plane != runs.front().plane)
      throw formats::DbbRunFormatError(r.source + ": plane " + r.plane + " differs from " + runs.front().source + " (" +
                                runs.front().plane + ")");
}

Problem assemble_problem(const std::vector<formats::DbbRun>& runs, const std::vector<Geo>& g, bool machine_time,
                         const std::vector<double>& reading_um) {
  Problem p;
  p.model = "dbb";
  p.domain = "angle_deg";
  p.runs = run_infos(runs);
  for (const auto& q : g) {
    double deg = std::fmod(q.zeta_rad * 180 / pi, 360.0);
    if (deg < 0) deg += 360;
    p.samples.push_back({q.run, q.dL_um, deg, q.t_s});
  }
  p.candidates = dbb_candidates(g, runs, machine_time, reading_um);
  if (!machine_time && runs.size() > 1) {
    p.notes.push_back("runs have no start_time_s metadata: a drift is fitted with its own offset per run, a vibration with its own phase");
    p.terms_per_run = true;
  }
  bool ccw = false, cw = false;
  for (const auto& r : runs) (r.dir() > 0 ? ccw : cw) = true;
  if (!(ccw && cw))
    p.notes.push_back("one direction only: servo_mismatch has the signature of squareness and cannot be told apart");
  return p;
}

}  // namespace

Problem dbb_problem(const std::vector<formats::DbbRun>& runs) {
  check_runs(runs);
  const bool machine_time = all_have_start_time(runs);
  const auto g = geometry(runs, machine_time);
  Block base = lai_base(g);
  Eigen::VectorXd y(static_cast<Eigen::Index>(g.size()));
  for (std::size_t i = 0; i < g.size(); ++i) y[static_cast<Eigen::Index>(i)] = g[i].dL_um;
  const LsqResult fit = solve_lsq(base.columns, y, Eigen::VectorXd(), base.names);
  if (!fit.ok) throw std::invalid_argument("explain: Lai base fit failed: " + fit.message);
  std::vector<double> reading(g.size());
  for (std::size_t i = 0; i < g.size(); ++i) reading[i] = y[static_cast<Eigen::Index>(i)] - fit.residual[static_cast<Eigen::Index>(i)];
  Problem p = assemble_problem(runs, g, machine_time, reading);
  refit_sensor_nonlinearity(p, base, y, {});
  // The yardstick of the contributions, as a ballbar's software ranks errors: the largest circular
  // deviation G of a run (ISO 230-4: the range of the reading about the run's least-squares circle), and
  // a finding's part of it the same range of its fitted term.
  p.deviation_name = "circular deviation G";
  auto spans = std::make_shared<std::vector<std::pair<std::size_t, std::vector<double>>>>();  // first sample, angles
  for (std::size_t i0 = 0; i0 < g.size();) {
    std::vector<double> zeta;
    std::size_t i1 = i0;
    for (; i1 < g.size() && g[i1].run == g[i0].run; ++i1) zeta.push_back(g[i1].zeta_rad);
    spans->emplace_back(i0, std::move(zeta));
    i0 = i1;
  }
  p.contribution_of = [spans](const Eigen::VectorXd& term_um) {
    double out = 0;
    for (const auto& [first, zeta] : *spans)
      out = std::max(out, dbb::range_about_circle(zeta, std::span<const double>(term_um.data() + first, zeta.size())));
    return out;
  };
  p.deviation_um = p.contribution_of(y);
  if (drive_delays_s(runs).size() > 1) {
    Candidate c{"servo_lag",
                "the drives follow the command late (the position loops' 1/Kv), so with the commanded angles every "
                "position-dependent error is seen a little earlier along the path, opposite in the two directions",
                {}, {}, 0};
    c.generate = servo_lag_generator(base, y, std::make_shared<const std::vector<Geo>>(g));
    p.candidates.push_back(std::move(c));
  }
  p.base = std::move(base);
  return p;
}

Problem dbb_compare_problem(const formats::DbbRun& simulated, const formats::DbbRun& measured) {
  if (simulated.angle_rad.size() != measured.angle_rad.size())
    throw std::invalid_argument("explain: " + simulated.source + " has " + std::to_string(simulated.angle_rad.size()) +
                                " samples, " + measured.source + " has " + std::to_string(measured.angle_rad.size()));
  for (std::size_t i = 0; i < simulated.angle_rad.size(); ++i)
    if (std::abs(simulated.angle_rad[i] - measured.angle_rad[i]) > 1e-6 * pi / 180)
      throw std::invalid_argument("explain: " + simulated.source + " and " + measured.source +
                                  " differ in angle at sample " + std::to_string(i + 1));
  formats::DbbRun diff = measured;
  for (std::size_t i = 0; i < diff.dL_m.size(); ++i) diff.dL_m[i] -= simulated.dL_m[i];
  const std::vector<formats::DbbRun> runs{diff};
  const bool machine_time = all_have_start_time(runs);
  const auto g = geometry(runs, machine_time);
  std::vector<double> reading(simulated.dL_m.size());
  for (std::size_t i = 0; i < reading.size(); ++i) reading[i] = simulated.dL_m[i] * 1e6;
  Problem p = assemble_problem(runs, g, machine_time, reading);
  p.model = "dbb (simulated vs measured)";
  p.notes.push_back("no base refit: the residual is " + measured.source + " - " + simulated.source);
  return p;
}

Report explain_dbb_report(const std::vector<formats::DbbRun>& runs, const ExplainOptions& options) {
  return explain(dbb_problem(runs), options);
}

nlohmann::json explain_dbb(const std::vector<formats::DbbRun>& runs, const ExplainOptions& options) {
  return to_json(explain_dbb_report(runs, options));
}

}  // namespace guideway::models::explain
