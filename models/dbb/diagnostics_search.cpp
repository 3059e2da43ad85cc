// Where the ballbar diagnostics' nonlinear terms sit (diagnostics_search.hpp).
#include "models/dbb/diagnostics_search.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "models/dbb/fast_sincos.hpp"

namespace guideway::models::dbb::fitting {

namespace {

// The cyclic-error phases of the chosen lead-screw periods, computed once for every later fit.
void set_cyclic_phases(const DiagLayout& L, std::vector<Point>& pts) {
  for (auto& p : pts) {
    if (L.cyclic_a) {
      const double th = 2 * pi * p.a_m / L.period_a;
      p.cyc_sa = std::sin(th);
      p.cyc_ca = std::cos(th);
    }
    if (L.cyclic_b) {
      const double th = 2 * pi * p.b_m / L.period_b;
      p.cyc_sb = std::sin(th);
      p.cyc_cb = std::cos(th);
    }
  }
}

// Weighted sum of squares explained by fitting two extra columns to a residual.
// With stride > 1 only every stride-th point is used and the result scaled back.
template <typename Cols>
double explained(const std::vector<Point>& pts, const Eigen::VectorXd& res, const Cols& cols, std::size_t stride = 1) {
  double s11 = 0, s12 = 0, s22 = 0, b1 = 0, b2 = 0;
  for (std::size_t i = 0; i < pts.size(); i += stride) {
    double u1 = 0, u2 = 0;
    cols(pts[i], u1, u2);
    const double w = pts[i].w;
    s11 += w * u1 * u1;
    s12 += w * u1 * u2;
    s22 += w * u2 * u2;
    b1 += w * u1 * res[static_cast<Eigen::Index>(i)];
    b2 += w * u2 * res[static_cast<Eigen::Index>(i)];
  }
  const double det = s11 * s22 - s12 * s12;
  if (!(det > 1e-300)) return 0.0;
  const double x1 = (s22 * b1 - s12 * b2) / det;
  const double x2 = (s11 * b2 - s12 * b1) / det;
  return (x1 * b1 + x2 * b2) * static_cast<double>(stride);
}

// A reversal spike of one axis as the search finds it: decay time and delay after the commanded reversal
// (s), height (um) and whether it explains clearly more than noise.
struct SpikeShape {
  double tau = assumed_spike_decay_s, delay = 0, amp = 0;
  bool significant = false;
};

// The points shortly after an axis' reversal, where a spike lives: time since the reversal, the spike
// column's value at decay 0, the weight and the preliminary fit's residual.
struct SpikePoint {
  double since, u, w, r;
};

// The least-squares sums of a spike of decay `tau` started `delay` after the reversal against the residual:
// sum w u r and sum w u^2.
std::pair<double, double> spike_sums(const std::vector<SpikePoint>& near, double tau, double delay) {
  double sur = 0, suu = 0;
  for (const auto& q : near) {
    const double t = q.since - delay;
    if (t < 0 || t > 8 * tau) continue;
    const double u = q.u * std::exp(-t / tau);
    sur += q.w * u * q.r;
    suu += q.w * u * u;
  }
  return {sur, suu};
}

// What a spike explains of the residual (sur^2 / suu), 0 when it reaches no point.
double spike_score(const std::vector<SpikePoint>& near, double tau, double delay) {
  const auto [sur, suu] = spike_sums(near, tau, delay);
  return suu > 0 ? sur * sur / suu : 0.0;
}

// Per axis: the decay time (log grid 2..100 ms, then golden section; never below half the sample spacing
// `dt`, where a "spike" would be one sample's noise) and the delay of the spike after the commanded
// reversal (the axis' servo lag, 0..`delay_max`) that explain most of the residual. When that is not
// clearly more than noise, a spike at the reversal decaying in 20 ms, or two sample spacings when the
// samples are further apart than 10 ms: the height then reported is that of a stiction spike the sampling
// resolves, consistent with none.
SpikeShape search_spike(const std::vector<Point>& pts, const LsqResult& base, bool axis_a, double delay_step,
                        double delay_max, double dt) {
  const double tau_min = 0.5 * dt;
  constexpr double tau_max = 0.1;
  std::vector<SpikePoint> near;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Point& p = pts[i];
    const double since = axis_a ? p.since_a_s : p.since_b_s;
    if (since > 8 * tau_max + delay_max) continue;
    const double u = p.lambda * (axis_a ? p.c * -p.sgn_a * p.rev_a : p.s * -p.sgn_b * p.rev_b);
    if (u == 0.0) continue;
    near.push_back({since, u, p.w, base.residual[static_cast<Eigen::Index>(i)]});
  }
  double best = 0, best_tau = assumed_spike_decay_s, best_delay = 0;
  constexpr int grid = 12;
  for (double d = 0; d <= delay_max + 1e-12; d += delay_step) {
    for (int q = 0; q < grid; ++q) {
      const double tau = 0.002 * std::pow(50.0, static_cast<double>(q) / (grid - 1));
      if (tau < tau_min) continue;
      const double e = spike_score(near, tau, d);
      if (e > best * (1 + 1e-9)) {  // ties (a delay shorter than the sample spacing): keep the shortest
        best = e;
        best_tau = tau;
        best_delay = d;
      }
    }
  }
  // Refine the delay (when the sampling resolves it) and the decay (golden section in log tau).
  for (double d = std::max(0.0, best_delay - delay_step); delay_step < 0.004 && d <= best_delay + delay_step + 1e-12;
       d += 0.25 * delay_step) {
    const double e = spike_score(near, best_tau, d);
    if (e > best * (1 + 1e-9)) {
      best = e;
      best_delay = d;
    }
  }
  const double ratio = std::pow(50.0, 1.0 / (grid - 1));
  double lo = std::log(std::max(best_tau / ratio, tau_min)), hi = std::log(best_tau * ratio);
  const double gr = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = hi - gr * (hi - lo), x2 = lo + gr * (hi - lo);
  double f1 = spike_score(near, std::exp(x1), best_delay), f2 = spike_score(near, std::exp(x2), best_delay);
  for (int it = 0; it < 14; ++it) {
    if (f1 > f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - gr * (hi - lo);
      f1 = spike_score(near, std::exp(x1), best_delay);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + gr * (hi - lo);
      f2 = spike_score(near, std::exp(x2), best_delay);
    }
  }
  const double xm = 0.5 * (lo + hi);
  if (spike_score(near, std::exp(xm), best_delay) > best) best_tau = std::exp(xm);
  if (!(spike_score(near, best_tau, best_delay) > 30.0 * base.s2))
    return {std::max(assumed_spike_decay_s, 2 * dt), 0.0, 0.0, false};
  const auto [sur, suu] = spike_sums(near, best_tau, best_delay);
  return {best_tau, best_delay, suu > 0 ? sur / suu : 0.0, true};
}

}  // namespace

void search_reversal_spikes(const std::vector<formats::DbbRun>& runs, const std::vector<Point>& pts,
                            const LsqResult& base, DiagLayout& L) {
  // Sample spacing: delays shorter than it cannot be told apart (ties keep the shortest).
  double dt = 1e9;
  for (const auto& run : runs)
    for (std::size_t i = 1; i < run.t_s.size(); ++i) dt = std::min(dt, std::max(run.t_s[i] - run.t_s[i - 1], 1e-4));
  // With samples further apart than 2 ms a delay only trades off against the height: not searched.
  const double delay_step = std::max(0.002, dt);
  const double delay_max = dt <= 0.002 ? 0.02 : 0.0;
  const SpikeShape a = search_spike(pts, base, true, delay_step, delay_max, dt);
  const SpikeShape b = search_spike(pts, base, false, delay_step, delay_max, dt);
  L.tau_a = a.tau;
  L.delay_a = a.delay;
  L.amp_a = a.amp;
  L.decay_a = a.significant;
  L.tau_b = b.tau;
  L.delay_b = b.delay;
  L.amp_b = b.amp;
  L.decay_b = b.significant;
  L.spikes = true;
}

void choose_cyclic_periods(const std::vector<formats::DbbRun>& runs, std::vector<Point>& pts, const LsqResult& base,
                           const IdentifyOptions& options, DiagLayout& L) {
  const double rmin =
      std::min_element(runs.begin(), runs.end(), [](const formats::DbbRun& a, const formats::DbbRun& b) {
        return a.radius_m < b.radius_m;
      })->radius_m;
  const std::vector<double> leads = {1, 1.5, 2, 2.5, 3, 4, 5, 6, 8, 10, 12, 16, 20, 25, 32, 40};
  // Largest arc length between samples: a lead p is sampled at least 4 times per period when only every
  // stride-th point is used, stride = p / (4 * step).
  double step = 0;
  for (std::size_t i = 1; i < pts.size(); ++i)
    if (pts[i].run == pts[i - 1].run)
      step = std::max(step, pts[i].radius_m * std::abs(pts[i].zeta_rad - pts[i - 1].zeta_rad));
  const auto stride_for = [step](double p) {
    return step > 0 ? std::max<std::size_t>(1, static_cast<std::size_t>(p / (4 * step))) : std::size_t{1};
  };
  const auto pick = [&](double given, bool axis_a) {
    if (given > 0) return given;
    double best = 0, best_p = 0;
    for (double lead_mm : leads) {
      const double p = lead_mm * 1e-3;
      if (p > rmin / 4) break;
      const double e = explained(
          pts, base.residual,
          [p, axis_a](const Point& q, double& u1, double& u2) {
            const double th = 2 * pi * (axis_a ? q.a_m : q.b_m) / p;
            const double f = q.lambda * (axis_a ? q.c : q.s);
            double sn, cs;
            fast_sincos(th, sn, cs);  // only compared between leads: libm's last bit is not needed
            u1 = f * sn;
            u2 = f * cs;
          },
          stride_for(p));
      if (e > best) {
        best = e;
        best_p = p;
      }
    }
    return best > 30.0 * base.s2 ? best_p : 0.0;
  };
  L.period_a = pick(options.cyclic_period_a_m, true);
  L.period_b = pick(options.cyclic_period_b_m, false);
  L.cyclic_a = L.period_a > 0;
  L.cyclic_b = L.period_b > 0;
  set_cyclic_phases(L, pts);
}

}  // namespace guideway::models::dbb::fitting
