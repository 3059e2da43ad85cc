#include "models/explain/dbb_explain.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdio>
#include <functional>
#include <memory>
#include <numbers>
#include <stdexcept>

#include <Eigen/QR>

#include "models/common/least_squares.hpp"
#include "models/dbb/identify.hpp"

namespace guideway::models::explain {

namespace {

constexpr double pi = std::numbers::pi;

double sgn(double x) { return x > 1e-9 ? 1.0 : (x < -1e-9 ? -1.0 : 0.0); }

// Per-sample geometry (as in models/dbb/identify.cpp, docs/conventions.md).
struct Geo {
  std::size_t run = 0;
  double zeta = 0, c = 0, s = 0, lam = 0, r = 0, h = 0, dir = 1, v = 0, omega = 0;
  double sgn_a = 0, sgn_b = 0;      // signs of the axis velocities
  double since_a = 0, since_b = 0;  // time since the last reversal of a / b (s)
  double a_m = 0, b_m = 0;          // machine coordinates of the commanded point
  double t_s = 0;                   // machine time since the earliest run's start (or run time when not all runs have start_time_s)
  double y_um = 0;
};

// Sums of w^2, w^2 t and w^2 t^2 over a run's samples (w a projection on the bar, t in s).
struct Moments {
  double w2 = 0, w2t = 0, w2t2 = 0;
};

std::string fmt(const char* f, double a) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, a);
  return buf;
}

std::string axis_letter(const std::string& plane, int which) {
  if (plane == "xz") return which == 0 ? "x" : "z";
  if (plane == "yz") return which == 0 ? "y" : "z";
  return which == 0 ? "x" : "y";
}

bool all_have_start_time(const std::vector<dbb::Run>& runs) {
  return std::all_of(runs.begin(), runs.end(), [](const dbb::Run& r) { return r.metadata.count("start_time_s") > 0; });
}

double start_time_of(const dbb::Run& r) {
  const std::string& s = r.metadata.at("start_time_s");
  try {
    std::size_t used = 0;
    const double v = std::stod(s, &used);
    if (used != s.size() || !std::isfinite(v)) throw std::invalid_argument(s);
    return v;
  } catch (const std::exception&) {
    throw dbb::RunFormatError(r.source + ": start_time_s: not a number: '" + s + "'");
  }
}

std::vector<Geo> geometry(const std::vector<dbb::Run>& runs, bool machine_time) {
  // Time counts from the earliest run's start: a Unix-epoch clock (~1.8e9 s) would make a drift
  // column nearly constant and cost a sinusoid's phase its digits.
  double origin_s = 0.0;
  if (machine_time) {
    origin_s = start_time_of(runs.front());
    for (const auto& run : runs) origin_s = std::min(origin_s, start_time_of(run));
  }
  std::vector<Geo> g;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const dbb::Run& run = runs[k];
    dbb::validate_run(run);
    const double l0 = run.nominal_length_m();
    const double t0 = machine_time ? start_time_of(run) - origin_s : 0.0;
    for (std::size_t i = 0; i < run.angle_rad.size(); ++i) {
      Geo p;
      p.run = k;
      p.zeta = run.angle_rad[i];
      p.c = std::cos(p.zeta);
      p.s = std::sin(p.zeta);
      p.r = run.radius_m;
      p.h = run.height_m;
      p.lam = run.radius_m / l0;
      p.dir = run.dir();
      p.v = run.feed_m_per_s;
      p.omega = run.feed_m_per_s / run.radius_m;
      p.sgn_a = -p.dir * sgn(p.s);
      p.sgn_b = p.dir * sgn(p.c);
      const auto since = [&](double phase) {
        const double q = (p.zeta - phase) / pi;
        const double last = p.dir > 0 ? std::floor(q) : std::ceil(q);
        return std::abs(p.zeta - phase - last * pi) / p.omega;
      };
      p.since_a = since(0.0);
      p.since_b = since(pi / 2);
      p.a_m = run.center_a_m + run.radius_m * p.c;
      p.b_m = run.center_b_m + run.radius_m * p.s;
      p.t_s = t0 + run.t_s[i];
      p.y_um = run.dL_m[i] * 1e6;
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
    const auto ch = dbb::lai3_characteristics(g[i].r, g[i].h, static_cast<int>(g[i].dir), g[i].v, g[i].zeta);
    for (std::size_t k = 0; k < lai_geometric; ++k)
      b.columns(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(k)) = ch[k] * lai_si_per_reported[k] * 1e6;
  }
  return b;
}


// Lost motion per unit backlash of a deadband of width b_a / b_b (m) driven by the commanded circle
// (as models/dbb/identify.cpp): the axis stands still at a reversal until the drive has taken up the
// play, which an ideal step does not describe. out[i] = {a, b}; simulated from half a turn before.
std::vector<std::array<double, 2>> deadband(const std::vector<Geo>& g, const std::vector<dbb::Run>& runs, double b_a,
                                            double b_b) {
  std::vector<std::array<double, 2>> out(g.size());
  for (std::size_t i = 0; i < g.size(); ++i) out[i] = {-0.5 * g[i].sgn_a, -0.5 * g[i].sgn_b};
  std::size_t i0 = 0;
  for (const auto& run : runs) {
    const double r = run.radius_m, dir = run.dir();
    for (int axis = 0; axis < 2; ++axis) {
      const double b = axis == 0 ? b_a : b_b;
      if (!(b > 0)) continue;
      const auto cmd = [&](double z) { return axis == 0 ? r * std::cos(z) : r * std::sin(z); };
      const double half = 0.5 * b;
      double z = run.angle_rad.front() - dir * pi;
      double act = cmd(z);
      const double near = 4.0 * std::sqrt(b / r) + 0.01;
      const auto advance = [&](double to) {
        const double rev = axis == 0 ? std::abs(std::sin(to)) : std::abs(std::cos(to));
        const int steps =
            rev > near ? 1 : std::max(1, static_cast<int>(std::ceil(std::abs(to - z) / (0.01 * pi / 180))));
        const double dz = (to - z) / steps;
        for (int q = 1; q <= steps; ++q) {
          const double c = cmd(z + dz * q);
          if (c - act > half) act = c - half;
          if (c - act < -half) act = c + half;
        }
        z = to;
      };
      const double z0 = run.angle_rad.front();
      for (int q = 1; q < 1800; ++q) advance(z0 - dir * pi + dir * q * (pi / 1800));
      for (std::size_t i = 0; i < run.angle_rad.size(); ++i) {
        advance(run.angle_rad[i]);
        out[i0 + i][static_cast<std::size_t>(axis)] = (act - cmd(z)) / b;
      }
    }
    i0 += run.angle_rad.size();
  }
  return out;
}

double spike(double t, double tau) { return (t < 0 || t > 8 * tau) ? 0.0 : std::exp(-t / tau); }

// `reading_um`: the reading the model predicts per sample (the sensor's operating point; taking the
// measured value would let the candidate fit the very effects in it).
std::vector<Candidate> dbb_candidates(const std::vector<Geo>& g, const std::vector<dbb::Run>& runs, bool machine_time,
                                      const std::vector<double>& reading_um) {
  const std::string A = axis_letter(runs.front().plane, 0), B = axis_letter(runs.front().plane, 1);
  std::vector<Candidate> out;
  {
    Candidate c{"servo_mismatch",
                "the two axes' position loops lag by different times, so the circle is stretched along a diagonal by "
                "an amount that grows with feed and flips with direction",
                {}, {}, 0};
    c.variants.push_back(make_variant(g, {"servo_mismatch_ms"}, [](const Geo& p, double* o) {
      o[0] = p.lam * p.dir * p.v * p.s * p.c * 1e3;  // 1 ms of lag difference; v in m/s -> um
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
    // inward spike at every reversal that another candidate would otherwise claim).
    const auto geo = std::make_shared<const std::vector<Geo>>(g);
    const auto rs = std::make_shared<const std::vector<dbb::Run>>(runs);
    c.generate = [geo, rs, names](const Eigen::VectorXd& r, const std::vector<bool>& use) {
      const auto& gg = *geo;
      std::vector<Variant> vs;
      vs.push_back(make_variant(gg, names, [](const Geo& p, double* o) {
        o[0] = -p.lam * 0.5 * p.sgn_a * p.c;
        o[1] = -p.lam * 0.5 * p.sgn_b * p.s;
      }));
      // The step's size from the rows in use only (a held-out row's zero residual would shrink it).
      std::vector<Eigen::Index> rows;
      for (std::size_t i = 0; i < use.size(); ++i)
        if (use[i]) rows.push_back(static_cast<Eigen::Index>(i));
      const Eigen::MatrixXd step = vs.front().block.columns(rows, Eigen::all);
      const Eigen::Vector2d b = step.colPivHouseholderQr().solve(Eigen::VectorXd(r(rows)));
      const double ba = std::max(0.0, b[0]) * 1e-6, bb = std::max(0.0, b[1]) * 1e-6;
      if (ba > 0 || bb > 0) {
        const auto db = deadband(gg, *rs, ba, bb);
        Variant v;
        v.block.names = names;
        v.block.columns.resize(static_cast<Eigen::Index>(gg.size()), 2);
        for (std::size_t i = 0; i < gg.size(); ++i) {
          v.block.columns(static_cast<Eigen::Index>(i), 0) = gg[i].lam * db[i][0] * gg[i].c;
          v.block.columns(static_cast<Eigen::Index>(i), 1) = gg[i].lam * db[i][1] * gg[i].s;
        }
        vs.push_back(std::move(v));
      }
      return vs;
    };
    c.search_size = 1;
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
                                 o[0] = p.lam * p.c * (-p.sgn_a) * spike(p.since_a, tau);
                                 o[1] = p.lam * p.s * (-p.sgn_b) * spike(p.since_b, tau);
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
    c.variants.push_back(make_variant(g, {"lateral_play_" + A + "_um", "lateral_play_" + B + "_um"},
                                      [](const Geo& p, double* o) {
                                        o[0] = p.lam * 0.5 * p.sgn_a * p.s;
                                        o[1] = p.lam * 0.5 * p.sgn_b * p.c;
                                      }));
    out.push_back(std::move(c));
  }
  {
    Candidate c{"cyclic_error",
                "a lead-screw (or scale) pitch error repeats every lead along the axis, at the same position in every run",
                {}, {}, 0};
    for (int axis = 0; axis < 2; ++axis) {
      const std::string L = axis == 0 ? A : B;
      for (double p_mm : {1.0, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 12.5, 15.0, 16.0, 20.0, 25.0, 32.0, 40.0}) {
        const double period = p_mm * 1e-3;
        Variant v = make_variant(g, {"cyclic_sin_" + L, "cyclic_cos_" + L}, [=](const Geo& p, double* o) {
          const double th = 2 * pi * (axis == 0 ? p.a_m : p.b_m) / period;
          const double proj = p.lam * (axis == 0 ? p.c : p.s);
          o[0] = proj * std::sin(th);
          o[1] = proj * std::cos(th);
        });
        v.fixed.push_back({"cyclic_period_" + L + "_mm", p_mm, std::numeric_limits<double>::quiet_NaN()});
        v.searched = 1;
        v.report = [L](const Eigen::VectorXd& x, const Eigen::MatrixXd& cov) {
          return amp_phase("cyclic_error_" + L + "_um", "cyclic_phase_" + L + "_deg", x, cov);
        };
        c.variants.push_back(std::move(v));
      }
    }
    out.push_back(std::move(c));
  }
  {
    Candidate c{"thermal_drift",
                "the machine or the bar grows as it warms up, a trend in time that the geometric terms only partly absorb",
                {}, {}, 0};
    const std::size_t nr = runs.size();
    // Without a common time axis each run after the first gets its own offset.
    const std::size_t offsets = machine_time ? 0 : nr - 1;
    for (int which = 0; which < 3; ++which) {
      std::vector<std::string> names{which == 0 ? "bar_drift_um_per_min"
                                                : "drift_" + (which == 1 ? A : B) + "_um_per_min"};
      for (std::size_t k = 1; k <= offsets; ++k) names.push_back("drift_offset_run" + std::to_string(k + 1) + "_um");
      c.variants.push_back(make_variant(g, names, [=](const Geo& p, double* o) {
        const double proj = which == 0 ? 1.0 : p.lam * (which == 1 ? p.c : p.s);
        o[0] = proj * p.t_s / 60.0;
        if (offsets && p.run >= 1) o[p.run] = 1.0;
      }));
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
      constexpr std::size_t max_grid = 8192;  // bounds the direct periodogram's cost
      const double f_lo = 4.0 / t_span, f_hi = 0.4 / dt, df = std::max(0.25 / t_span, (f_hi - f_lo) / max_grid);
      const auto grid = static_cast<std::size_t>(std::max(0.0, (f_hi - f_lo) / df));
      c.search_size = 3 * grid;
      auto geo = std::make_shared<const std::vector<Geo>>(g);
      // Held-out rows have residual 0: the periodogram is that of the rows in use.
      // Without a common clock a line keeps its frequency and amplitude from run to run but not its
      // phase: each run gets its own sine and cosine (the periodogram already sums runs' powers).
      const std::size_t phases = machine_time ? 1 : runs.size();
      // Two lines closer than the Fourier resolution 1/t_span are one line: the second strongest is
      // sought at least that far from the first (the grid oversamples it 4x).
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
          const double w = which == 0 ? 1.0 : p.lam * (which == 1 ? p.c : p.s);
          Moments& m = mom[p.run];
          m.w2 += w * w;
          m.w2t += w * w * p.t_s;
          m.w2t2 += w * w * p.t_s * p.t_s;
        }
      }
      c.generate = [geo, f_lo, df, grid, apart, A, B, phases, moments](const Eigen::VectorXd& r,
                                                                       const std::vector<bool>&) {
        const auto& gg = *geo;
        // One periodogram per direction the vibration may have (the bar, axis A, axis B), each of the
        // residual weighted by that direction's projection on the bar: a vibration of axis A at f reads
        // as lam cos(zeta) sin(2 pi f t), whose plain periodogram peaks at f +- the circling frequency,
        // not at f. Power summed over runs: sum over runs of |sum_i w_i r_i exp(-2 pi i f_q t_i)|^2.
        // Per sample, successive grid frequencies turn the phasor by exp(-2 pi i df t) (re-anchored
        // every 64 points against rounding): a complex multiply instead of a sine and cosine per sample
        // and frequency, shared by the three directions.
        constexpr std::size_t dirs = 3;
        std::vector<double> pw(dirs * grid, 0.0), re(dirs * grid), im(dirs * grid);
        constexpr std::size_t anchor = 64;
        for (std::size_t i = 0; i < gg.size();) {
          std::fill(re.begin(), re.end(), 0.0);
          std::fill(im.begin(), im.end(), 0.0);
          for (const std::size_t run = gg[i].run; i < gg.size() && gg[i].run == run; ++i) {
            const double ri = r[static_cast<Eigen::Index>(i)];
            if (ri == 0.0) continue;  // a held-out row
            const double t = gg[i].t_s;
            const double wa = gg[i].lam * gg[i].c, wb = gg[i].lam * gg[i].s;
            const double sr = std::cos(-2 * pi * df * t), si = std::sin(-2 * pi * df * t);
            for (std::size_t q0 = 0; q0 < grid; q0 += anchor) {
              const std::complex<double> z0 = ri * std::polar(1.0, -2 * pi * (f_lo + df * static_cast<double>(q0)) * t);
              double zr = z0.real(), zi = z0.imag();
              for (std::size_t q = q0; q < std::min(grid, q0 + anchor); ++q) {
                double* qr = &re[dirs * q];
                double* qi = &im[dirs * q];
                qr[0] += zr;
                qi[0] += zi;
                qr[1] += wa * zr;
                qi[1] += wa * zi;
                qr[2] += wb * zr;
                qi[2] += wb * zi;
                const double nr = zr * sr - zi * si;
                zi = zr * si + zi * sr;
                zr = nr;
              }
            }
          }
          for (std::size_t k = 0; k < dirs * grid; ++k) pw[k] += re[k] * re[k] + im[k] * im[k];
        }
        std::vector<Variant> vs;
        for (int which = 0; which < 3; ++which) {
          const auto at = [&](std::size_t q) { return pw[dirs * q + static_cast<std::size_t>(which)]; };
          std::vector<std::pair<double, std::size_t>> power;  // (power, grid index)
          for (std::size_t q = 0; q < grid; ++q) power.emplace_back(at(q), q);
          std::sort(power.begin(), power.end(), std::greater<>());
          std::vector<std::size_t> lines;
          for (const auto& [pw_q, q] : power) {
            if (lines.size() == 2) break;
            if (lines.empty() || (q > lines[0] ? q - lines[0] : lines[0] - q) >= apart) lines.push_back(q);
          }
          for (const std::size_t q : lines) {
            // Between grid points by the parabola through the peak and its neighbours: a coherent fit
            // over runs a minute apart loses much of a line that is a fraction of a grid step off.
            double offset = 0.0;
            if (q > 0 && q + 1 < grid) {
              const double curvature = at(q - 1) - 2 * at(q) + at(q + 1);
              if (curvature < 0) offset = std::clamp(0.5 * (at(q - 1) - at(q + 1)) / curvature, -0.5, 0.5);
            }
            const double f = f_lo + df * (static_cast<double>(q) + offset);
            const std::vector<Moments>& mom = moments[static_cast<std::size_t>(which)];
            const std::string L = which == 0 ? "bar" : (which == 1 ? A : B);
            std::vector<std::string> names;
            for (std::size_t run_k = 0; run_k < phases; ++run_k) {
              const std::string run = phases > 1 ? "_run" + std::to_string(run_k + 1) : "";
              names.push_back("vibration_sin" + run);
              names.push_back("vibration_cos" + run);
            }
            Variant v = make_variant(gg, names, [=](const Geo& p, double* o) {
              const double proj = which == 0 ? 1.0 : p.lam * (which == 1 ? p.c : p.s);
              const std::size_t col = phases > 1 ? 2 * p.run : 0;
              o[col] = proj * std::sin(2 * pi * f * p.t_s);
              o[col + 1] = proj * std::cos(2 * pi * f * p.t_s);
            });
            v.searched = 1;
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
    // Stick-slip: a decaying oscillation of the axis after it reverses (low speed near the reversal).
    Candidate c{"stick_slip",
                "friction at low speed makes an axis move in jerks just after it reverses, a decaying oscillation",
                {}, {}, 0};
    for (double f_hz : {5.0, 10.0, 20.0}) {
      for (double tau_ms : {50.0, 200.0}) {
        const double tau = tau_ms * 1e-3;
        Variant v = make_variant(g, {"stick_slip_" + A + "_um", "stick_slip_" + B + "_um"}, [=](const Geo& p, double* o) {
          o[0] = p.lam * p.c * spike(p.since_a, tau) * std::sin(2 * pi * f_hz * p.since_a);
          o[1] = p.lam * p.s * spike(p.since_b, tau) * std::sin(2 * pi * f_hz * p.since_b);
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

std::vector<RunInfo> run_infos(const std::vector<dbb::Run>& runs) {
  std::vector<RunInfo> out;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const auto& r = runs[k];
    RunInfo ri;
    ri.label = "run" + std::to_string(k + 1) + " (" + (r.dir() > 0 ? "ccw" : "cw") + ")";
    ri.direction = r.dir();
    ri.feed_mm_per_min = std::round(r.feed_m_per_s * 60000.0 * 1e6) / 1e6;
    ri.geometry = fmt("r%.6g", r.radius_m * 1e3) + fmt("h%.6g", r.height_m * 1e3) + r.plane;
    out.push_back(ri);
  }
  return out;
}

void check_runs(const std::vector<dbb::Run>& runs) {
  if (runs.empty()) throw std::invalid_argument("explain: no runs");
  for (const auto& r : runs)
    if (r.plane != runs.front().plane)
      throw dbb::RunFormatError(r.source + ": plane " + r.plane + " differs from " + runs.front().source + " (" +
                                runs.front().plane + ")");
}

Problem assemble_problem(const std::vector<dbb::Run>& runs, const std::vector<Geo>& g, bool machine_time,
                         const std::vector<double>& reading_um) {
  Problem p;
  p.model = "dbb";
  p.domain = "angle_deg";
  p.runs = run_infos(runs);
  for (const auto& q : g) {
    double deg = std::fmod(q.zeta * 180 / pi, 360.0);
    if (deg < 0) deg += 360;
    p.samples.push_back({q.run, q.y_um, deg, q.t_s});
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

Problem dbb_problem(const std::vector<dbb::Run>& runs) {
  check_runs(runs);
  const bool machine_time = all_have_start_time(runs);
  const auto g = geometry(runs, machine_time);
  Block base = lai_base(g);
  Eigen::VectorXd y(static_cast<Eigen::Index>(g.size()));
  for (std::size_t i = 0; i < g.size(); ++i) y[static_cast<Eigen::Index>(i)] = g[i].y_um;
  const LsqResult fit = solve_lsq(base.columns, y, Eigen::VectorXd(), base.names);
  if (!fit.ok) throw std::invalid_argument("explain: Lai base fit failed: " + fit.message);
  std::vector<double> reading(g.size());
  for (std::size_t i = 0; i < g.size(); ++i) reading[i] = y[static_cast<Eigen::Index>(i)] - fit.residual[static_cast<Eigen::Index>(i)];
  Problem p = assemble_problem(runs, g, machine_time, reading);
  refit_sensor_nonlinearity(p, base, y, {});
  p.base = std::move(base);
  return p;
}

Problem dbb_compare_problem(const dbb::Run& simulated, const dbb::Run& measured) {
  if (simulated.angle_rad.size() != measured.angle_rad.size())
    throw std::invalid_argument("explain: " + simulated.source + " has " + std::to_string(simulated.angle_rad.size()) +
                                " samples, " + measured.source + " has " + std::to_string(measured.angle_rad.size()));
  for (std::size_t i = 0; i < simulated.angle_rad.size(); ++i)
    if (std::abs(simulated.angle_rad[i] - measured.angle_rad[i]) > 1e-6 * pi / 180)
      throw std::invalid_argument("explain: " + simulated.source + " and " + measured.source +
                                  " differ in angle at sample " + std::to_string(i + 1));
  dbb::Run diff = measured;
  for (std::size_t i = 0; i < diff.dL_m.size(); ++i) diff.dL_m[i] -= simulated.dL_m[i];
  const std::vector<dbb::Run> runs{diff};
  const bool machine_time = all_have_start_time(runs);
  const auto g = geometry(runs, machine_time);
  std::vector<double> reading(simulated.dL_m.size());
  for (std::size_t i = 0; i < reading.size(); ++i) reading[i] = simulated.dL_m[i] * 1e6;
  Problem p = assemble_problem(runs, g, machine_time, reading);
  p.model = "dbb (simulated vs measured)";
  p.notes.push_back("no base refit: the residual is " + measured.source + " - " + simulated.source);
  return p;
}

Report explain_dbb_report(const std::vector<dbb::Run>& runs, const ExplainOptions& options) {
  return explain(dbb_problem(runs), options);
}

nlohmann::json explain_dbb(const std::vector<dbb::Run>& runs, const ExplainOptions& options) {
  return to_json(explain_dbb_report(runs, options));
}

}  // namespace guideway::models::explain
