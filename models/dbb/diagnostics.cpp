// The ballbar diagnostics of DBB runs (diagnostics.hpp).
#include "models/dbb/diagnostics.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Core>

#include "models/common/amplitude_phase.hpp"
#include "models/dbb/diagnostics_search.hpp"
#include "results/parameters.hpp"

namespace guideway::models::dbb::fitting {

namespace {

// Column values in um per reported unit (um, ppm, urad, ms).
void diag_row(const DiagLayout& L, const Point& p, Eigen::RowVectorXd& row) {
  row.setZero();
  const double c = p.c, s = p.s, lam = p.lambda, r = p.radius_m;
  row[static_cast<Eigen::Index>(2 * p.run)] = lam * c;
  row[static_cast<Eigen::Index>(2 * p.run + 1)] = lam * s;
  const auto g = static_cast<Eigen::Index>(L.global0());
  row[g + DiagLayout::scale_a] = lam * r * c * c;  // 1 ppm = 1e-6 * r m = r um
  row[g + DiagLayout::scale_b] = lam * r * s * s;
  row[g + DiagLayout::squareness] = lam * r * s * c;
  row[g + DiagLayout::backlash_a] = lam * p.bl_a * c * p.rev_a;
  row[g + DiagLayout::backlash_b] = lam * p.bl_b * s * p.rev_b;
  row[g + DiagLayout::play_a] = lam * 0.5 * p.sgn_a * s * p.rev_a;
  row[g + DiagLayout::play_b] = lam * 0.5 * p.sgn_b * c * p.rev_b;
  row[g + DiagLayout::servo] = lam * p.dir * p.feed_m_per_s * s * c * 1e3;  // 1 ms = 1e-3 s; v m/s -> um: *1e6*1e-3
  row[g + DiagLayout::bow_a] = lam * s * c * c;
  row[g + DiagLayout::bow_b] = lam * c * s * s;
  // (a3 c^3 s + b3 s^3 c) r^3 = (a3 + b3) r^3 sin 2 zeta / 4 + (a3 - b3) r^3 s c (c^2 - s^2) / 2: the first part
  // is a squareness, the second (a 4th harmonic) this term. On an evenly sampled full circle it is orthogonal
  // to every other column, but not once a gap takes samples away: left out, its ~1 um then went into the
  // backlash, play, servo mismatch and squareness (docs/conventions.md, "Planes and partial arcs").
  row[g + DiagLayout::cubic] = lam * 0.5 * s * c * (c * c - s * s);
  if (L.spikes) {
    const auto k = static_cast<Eigen::Index>(L.spike0());
    row[k] = lam * c * (-p.sgn_a) * reversal_spike_decay(p.since_a_s - L.delay_a, L.tau_a) * p.rev_a;
    row[k + 1] = lam * s * (-p.sgn_b) * reversal_spike_decay(p.since_b_s - L.delay_b, L.tau_b) * p.rev_b;
  }
  // d/dtau of A exp(-t/tau) = A t / tau^2 exp(-t/tau), per ms of tau.
  if (L.decay_a) {
    const double t = p.since_a_s - L.delay_a;
    row[static_cast<Eigen::Index>(L.decay_a0())] =
        lam * c * (-p.sgn_a) * L.amp_a * t / (L.tau_a * L.tau_a) * reversal_spike_decay(t, L.tau_a) * 1e-3;
  }
  if (L.decay_b) {
    const double t = p.since_b_s - L.delay_b;
    row[static_cast<Eigen::Index>(L.decay_b0())] =
        lam * s * (-p.sgn_b) * L.amp_b * t / (L.tau_b * L.tau_b) * reversal_spike_decay(t, L.tau_b) * 1e-3;
  }
  if (L.cyclic_a) {
    const auto k = static_cast<Eigen::Index>(L.cyc_a0());
    row[k] = lam * c * p.cyc_sa;
    row[k + 1] = lam * c * p.cyc_ca;
  }
  if (L.cyclic_b) {
    const auto k = static_cast<Eigen::Index>(L.cyc_b0());
    row[k] = lam * s * p.cyc_sb;
    row[k + 1] = lam * s * p.cyc_cb;
  }
  for (std::size_t k = 0; k < L.beside_count(); ++k)
    row[static_cast<Eigen::Index>(L.beside0() + k)] = L.beside->at(k, p);
}

std::vector<std::string> diag_names(const DiagLayout& L, const std::string& plane) {
  const auto both = [&](const results::Parameter& p, std::vector<std::string>& n) {
    n.push_back(results::name(p, plane, 0));
    n.push_back(results::name(p, plane, 1));
  };
  std::vector<std::string> n;
  for (std::size_t k = 0; k < L.runs; ++k) {
    // One run: plain names; several: run1.center_offset_*, run2.center_offset_*, ...
    for (int axis = 0; axis < 2; ++axis) {
      const std::string name = results::name(results::center_offset, plane, axis);
      n.push_back(L.runs > 1 ? results::run_prefixed(static_cast<int>(k + 1), name) : name);
    }
  }
  both(results::scale, n);
  n.push_back(results::name(results::squareness));
  both(results::backlash, n);
  both(results::lateral_play, n);
  n.push_back(results::name(results::servo_mismatch));
  both(results::straightness_bow, n);
  n.push_back(results::name(results::straightness_cubic_difference, plane));
  if (L.spikes) both(results::reversal_spike, n);
  if (L.decay_a) n.push_back(results::name(results::reversal_spike_decay, plane, 0));
  if (L.decay_b) n.push_back(results::name(results::reversal_spike_decay, plane, 1));
  if (L.cyclic_a) {
    n.push_back(results::name(results::cyclic_sin, plane, 0));
    n.push_back(results::name(results::cyclic_cos, plane, 0));
  }
  if (L.cyclic_b) {
    n.push_back(results::name(results::cyclic_sin, plane, 1));
    n.push_back(results::name(results::cyclic_cos, plane, 1));
  }
  if (L.beside) n.insert(n.end(), L.beside->names.begin(), L.beside->names.end());
  return n;
}

LsqResult fit_diag(const DiagLayout& L, const std::vector<Point>& pts, const std::string& plane, FitWork& work,
                   Eigen::Index stride = 1) {
  const auto n = static_cast<Eigen::Index>(pts.size());
  if (work.j.rows() != n || work.j.cols() < static_cast<Eigen::Index>(L.count()))
    work.j.resize(n, static_cast<Eigen::Index>(L.count()));
  auto j = work.j.leftCols(static_cast<Eigen::Index>(L.count()));
  if (work.y.size() != n) {
    work.y.resize(n);
    work.w.resize(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      work.y[i] = pts[static_cast<std::size_t>(i)].dL_um;
      work.w[i] = pts[static_cast<std::size_t>(i)].w;
    }
  }
  Eigen::RowVectorXd row(j.cols());
  for (Eigen::Index i = 0; i < n; ++i) {
    diag_row(L, pts[static_cast<std::size_t>(i)], row);
    j.row(i) = row;
  }
  return solve_strided(j, work.y, work.w, diag_names(L, plane), stride);
}

// Each diagnosed error's part of the circular deviation, as a ballbar's software ranks them ("what to
// fix first"): the range of its fitted term about the least-squares circle over a run (the largest over
// the runs), as G is the reading's, and that as a percentage of the largest G. The centre offset is the
// set-up's, not the machine's, and is not ranked. Terms partly cancel: the percentages need not add up
// to 100.
void rank_contributions(const DiagLayout& L, const LsqResult& res, const std::vector<Point>& pts,
                        const std::vector<formats::DbbRun>& runs, const std::vector<std::string>& names,
                        const std::string& plane, Identification& out) {
  const std::size_t g = L.global0();
  std::vector<std::vector<std::size_t>> terms{{g + DiagLayout::scale_a, g + DiagLayout::scale_b}};  // scale mismatch
  for (auto k : {DiagLayout::squareness, DiagLayout::backlash_a, DiagLayout::backlash_b, DiagLayout::play_a,
                 DiagLayout::play_b, DiagLayout::servo, DiagLayout::bow_a, DiagLayout::bow_b, DiagLayout::cubic})
    terms.push_back({g + k});
  if (L.spikes) {
    terms.push_back({L.spike0()});
    terms.push_back({L.spike0() + 1});
  }
  if (L.cyclic_a) terms.push_back({L.cyc_a0(), L.cyc_a0() + 1});
  if (L.cyclic_b) terms.push_back({L.cyc_b0(), L.cyc_b0() + 1});
  double g_max = 0;
  for (std::size_t k = 0, i = 0; k < runs.size(); i += runs[k].angle_rad.size(), ++k)
    g_max = std::max(g_max, circular_deviation(pts.data() + i, runs[k].angle_rad.size()));
  Eigen::RowVectorXd row(static_cast<Eigen::Index>(L.count()));
  for (const auto& cols : terms) {
    if (std::any_of(cols.begin(), cols.end(), [&](std::size_t c) { return !res.identified[c]; })) continue;
    std::vector<double> curve(pts.size(), 0.0);
    for (std::size_t i = 0; i < pts.size(); ++i) {
      diag_row(L, pts[i], row);
      for (const std::size_t c : cols)
        curve[i] += row[static_cast<Eigen::Index>(c)] * res.x[static_cast<Eigen::Index>(c)];
    }
    const double part = part_of_deviation(pts, curve, runs.size());
    // Named as the diagnostic (the scales as their mismatch, the cyclic error's two columns after its axis).
    std::string name = names[cols.front()];
    if (cols.front() == g + DiagLayout::scale_a)
      name = results::name(results::scale_mismatch);
    else if (cols.size() == 2)
      name = results::name(results::cyclic_error, plane, L.cyclic_a && cols.front() == L.cyc_a0() ? 0 : 1);
    out.ranking.push_back({name, part, g_max > 0 ? 100 * part / g_max : nan});
  }
  std::sort(out.ranking.begin(), out.ranking.end(),
            [](const Contribution& a, const Contribution& b) { return a.contribution_um > b.contribution_um; });
}

// The diagnostics fit with the deadband of its own backlash (the points carry `shaped`, Lai's): its drive
// delay searched again with the diagnostics' terms (the spikes among them) in the fit, its width refitted
// when it differs noticeably from the one the points carry.
LsqResult fit_with_own_backlash(std::vector<Point>& pts, const std::vector<DriveTrack>& tracks,
                                const std::string& plane, FitWork& work, Deadband shaped, const DiagLayout& L) {
  const auto fit = [&](Eigen::Index stride) { return solved(fit_diag(L, pts, plane, work, stride)); };
  const auto own = [&](const LsqResult& res) {
    const std::size_t ga = L.global0() + DiagLayout::backlash_a;
    return Deadband{res.identified[ga] ? res.x[static_cast<Eigen::Index>(ga)] * 1e-6 : 0.0,
                    res.identified[ga + 1] ? res.x[static_cast<Eigen::Index>(ga + 1)] * 1e-6 : 0.0, shaped.track};
  };
  const auto differs = [](const Deadband& now, const Deadband& was) {
    const auto by = [](double n, double w) { return std::abs(n - w) > std::max(0.02 * std::abs(w), 0.02e-6); };
    return by(now.b_a, was.b_a) || by(now.b_b, was.b_b);
  };
  LsqResult res = fit(1);
  Deadband now = own(res);
  if (now.shaped() && tracks.size() > 1) {
    shaped = choose_deadband_delay(pts, tracks, now, [&](const std::vector<Point>&) { return fit(3).rms; });
    res = fit(1);
    now = own(res);
  }
  if (differs(now, shaped)) {
    set_deadband(pts, tracks[now.track], std::max(now.b_a, 0.0), std::max(now.b_b, 0.0));
    res = fit(1);
  }
  return res;
}

// Gauss-Newton iterations on the spike decay times (linear in everything else).
void refine_spike_decays(const std::vector<Point>& pts, const std::string& plane, FitWork& work, DiagLayout& L,
                         LsqResult& res) {
  for (int it = 0; it < 4 && (L.decay_a || L.decay_b); ++it) {
    bool moved = false;
    const auto step = [&](bool on, std::size_t k_decay, std::size_t k_amp, double& tau, double& amp) {
      if (!on || !res.identified[k_decay]) return;
      const double d = res.x[static_cast<Eigen::Index>(k_decay)] * 1e-3;
      const double next = std::clamp(tau + d, 0.5 * tau, 2.0 * tau);
      if (std::abs(next - tau) > 0.002 * tau) moved = true;
      tau = next;
      amp = res.x[static_cast<Eigen::Index>(k_amp)];
    };
    step(L.decay_a, L.decay_a0(), L.spike0(), L.tau_a, L.amp_a);
    step(L.decay_b, L.decay_b0(), L.spike0() + 1, L.tau_b, L.amp_b);
    if (!moved) break;
    res = solved(fit_diag(L, pts, plane, work));
  }
}

// The cyclic error of one plane axis as amplitude, period and phase (from its sine and cosine columns,
// the amplitude's u to first order); an amplitude 0 without u when none was fitted.
void add_cyclic_error(const LsqResult& res, bool on, std::size_t k0, double period, const std::string& plane, int axis,
                      std::vector<Estimate>& out) {
  if (!on) {
    out.push_back(est(results::name(results::cyclic_error, plane, axis), 0.0, nan, false));
    return;
  }
  if (!res.identified[k0] || !res.identified[k0 + 1]) return;
  const auto i0 = static_cast<Eigen::Index>(k0);
  const AmplitudePhase line = amplitude_phase(res.x[i0], res.x[i0 + 1], res.covariance(i0, i0),
                                              res.covariance(i0 + 1, i0 + 1), res.covariance(i0, i0 + 1));
  const double amp = line.amplitude, u = line.u_amplitude;
  out.push_back(est(results::name(results::cyclic_error, plane, axis), amp, u));
  out.push_back(est(results::name(results::cyclic_period, plane, axis), period * 1e3, nan, false));
  // The phase of an amplitude within 2 u of zero is noise's (it printed as e.g. 6e-10 deg): not reported.
  if (std::isfinite(u) && amp > 2 * u)
    out.push_back(est(results::name(results::cyclic_phase, plane, axis), line.phase_rad * 180 / pi, nan, false));
}

// The diagnostics as reported: the fitted terms identified, the scale mismatch, the cyclic errors, the
// spikes' decays and delays.
void report_diagnostics(const DiagLayout& L, const LsqResult& res, const std::vector<std::string>& names,
                        const std::string& plane, Identification& out) {
  const auto add = [&](std::size_t idx) {
    if (!res.identified[idx]) return;
    out.diagnostics.push_back(
        est(names[idx], res.x[static_cast<Eigen::Index>(idx)], res.u[static_cast<Eigen::Index>(idx)]));
  };
  for (std::size_t k = 0; k < 2 * L.runs; ++k) add(k);
  const std::size_t g = L.global0();
  add(g + DiagLayout::scale_a);
  add(g + DiagLayout::scale_b);
  if (res.identified[g + DiagLayout::scale_a] && res.identified[g + DiagLayout::scale_b]) {
    const auto ia = static_cast<Eigen::Index>(g + DiagLayout::scale_a);
    const auto ib = static_cast<Eigen::Index>(g + DiagLayout::scale_b);
    const double var = res.covariance(ia, ia) + res.covariance(ib, ib) - 2 * res.covariance(ia, ib);
    out.diagnostics.push_back(
        est(results::name(results::scale_mismatch), res.x[ia] - res.x[ib], std::sqrt(std::max(var, 0.0))));
  }
  for (auto k : {DiagLayout::squareness, DiagLayout::backlash_a, DiagLayout::backlash_b, DiagLayout::play_a,
                 DiagLayout::play_b, DiagLayout::servo, DiagLayout::bow_a, DiagLayout::bow_b, DiagLayout::cubic})
    add(g + k);
  add(L.spike0());
  add(L.spike0() + 1);
  add_cyclic_error(res, L.cyclic_a, L.cyc_a0(), L.period_a, plane, 0, out.diagnostics);
  add_cyclic_error(res, L.cyclic_b, L.cyc_b0(), L.period_b, plane, 1, out.diagnostics);
  const auto decay = [&](bool fitted, std::size_t k, double tau, int axis) {
    const std::string name = results::name(results::reversal_spike_decay, plane, axis);
    if (fitted && res.identified[k]) {
      out.diagnostics.push_back(
          est(name, tau * 1e3 + res.x[static_cast<Eigen::Index>(k)], res.u[static_cast<Eigen::Index>(k)]));
    } else {
      out.diagnostics.push_back(est(name, tau * 1e3, nan, false));
    }
  };
  decay(L.decay_a, L.decay_a0(), L.tau_a, 0);
  decay(L.decay_b, L.decay_b0(), L.tau_b, 1);
  out.diagnostics.push_back(est(results::name(results::reversal_spike_delay, plane, 0), L.delay_a * 1e3, nan, false));
  out.diagnostics.push_back(est(results::name(results::reversal_spike_delay, plane, 1), L.delay_b * 1e3, nan, false));
  add_beside(res, names, L.beside0(), L.beside0() + L.beside_count(), out.beside);
}

// The ballbar diagnostics of `runs` (points `pts`, carrying the deadband `shaped` on the drives' `tracks`):
// fills out.diagnostics, out.diagnostics_fit and out.ranking; returns the final fit.
LsqResult diagnose(const std::vector<formats::DbbRun>& runs, std::vector<Point>& pts,
                   const std::vector<DriveTrack>& tracks, const std::string& plane, FitWork& work, Deadband shaped,
                   const IdentifyOptions& options, Identification& out) {
  DiagLayout L;
  L.runs = runs.size();
  const BesideColumns beside = beside_columns(options, true);
  L.beside = &beside;
  // Preliminary fit (a third of the points) whose residual steers the spike and cyclic searches.
  const LsqResult base = solved(fit_diag(L, pts, plane, work, 3));
  search_reversal_spikes(runs, pts, base, L);
  choose_cyclic_periods(runs, pts, base, options, L);
  LsqResult res = fit_with_own_backlash(pts, tracks, plane, work, shaped, L);
  refine_spike_decays(pts, plane, work, L, res);
  out.diagnostics_fit = summary_of(res);
  const auto names = diag_names(L, plane);
  add_bar_length_uncertainty(res, work.j.leftCols(static_cast<Eigen::Index>(L.count())), work.w, names,
                             options.bar_length_u_um);
  report_diagnostics(L, res, names, plane, out);
  rank_contributions(L, res, pts, runs, names, plane, out);
  out.ranking_model = "diagnostics";
  return res;
}

}  // namespace

std::vector<double> diagnose_in_plane_runs(const std::vector<formats::DbbRun>& runs, const std::string& plane,
                                           FitWork& work, const LaiFit& lai, const IdentifyOptions& options,
                                           Identification& out) {
  std::vector<formats::DbbRun> flat;
  std::vector<std::size_t> flat_index;  // into runs
  for (std::size_t k = 0; k < runs.size(); ++k)
    if (std::abs(runs[k].height_m) < 1e-9) {
      flat.push_back(runs[k]);
      flat_index.push_back(k);
    }
  std::vector<double> residual_rms(runs.size(), nan);
  // Among runs with a socket height, the h = 0 ones must also go both ways: in one direction backlash,
  // play, spikes and servo mismatch trade off against errors the diagnostics do not model (a single
  // in-plane test of one machine error at a time is separable; Lai's three patterns are not).
  const bool both = std::any_of(flat.begin(), flat.end(),
                                [](const formats::DbbRun& r) { return r.direction == formats::DbbDirection::ccw; }) &&
                    std::any_of(flat.begin(), flat.end(),
                                [](const formats::DbbRun& r) { return r.direction == formats::DbbDirection::cw; });
  if (flat.empty()) {
    out.notes.push_back(
        "no ballbar diagnostics: they model an in-plane bar (h = 0) and every run has a socket height; "
        "Lai's model covers these runs (and ranks the errors)");
  } else if (!both && flat.size() < runs.size()) {
    out.notes.push_back(
        "no ballbar diagnostics: they need an in-plane (h = 0) test in both directions (backlash, play, "
        "spikes and servo mismatch are told apart by the direction), and the h = 0 runs go one way; "
        "Lai's model covers every run (and ranks the errors)");
  } else {
    if (flat.size() < runs.size()) {
      std::string which;
      for (const auto& r : flat) which += (which.empty() ? "" : ", ") + r.source;
      out.notes.push_back("ballbar diagnostics from the h = 0 run(s) only (" + which +
                          "): they model an in-plane bar, not a socket height; Lai's model above uses every run");
    }
    std::vector<std::size_t> first(runs.size(), 0);  // of each run among all the runs
    for (std::size_t k = 1; k < runs.size(); ++k) first[k] = first[k - 1] + runs[k - 1].angle_rad.size();
    std::vector<std::size_t> flat_first;
    for (const std::size_t k : flat_index) flat_first.push_back(first[k]);
    std::vector<Point> flat_pts = points_of(flat, flat_first);
    const std::vector<DriveTrack> tracks =
        drive_tracks(flat_pts, drive_delays_s(runs));  // Lai's delays: its track index holds
    if (lai.shaped.shaped()) set_deadband(flat_pts, tracks[lai.shaped.track], lai.shaped.b_a, lai.shaped.b_b);
    const LsqResult res = diagnose(flat, flat_pts, tracks, plane, work, lai.shaped, options, out);
    // Absolute scales that agree are a radius change common to both axes, not the axes' scales.
    const auto find = [&](const std::string& name) -> const Estimate* {
      for (const auto& e : out.diagnostics)
        if (e.name == name) return &e;
      return nullptr;
    };
    const Estimate* sa = find(results::name(results::scale, plane, 0));
    const Estimate* sb = find(results::name(results::scale, plane, 1));
    if (sa && sb) {
      const double common = 0.5 * (sa->value + sb->value), mismatch = sa->value - sb->value;
      if (std::abs(common) > 50 && std::abs(common) > 3 * std::abs(mismatch)) {
        std::ostringstream o;
        o << "both axes' scales read about " << std::lround(common)
          << " ppm: a radius change common to both (a position "
          << "loop's lag tau shrinks a circle by r (omega tau)^2 / 2 at high feed, 346 ppm for 30 ms at 5000 mm/min on "
          << "95 mm; a bar calibration error) rather than the axes' own scales; "
          << results::name(results::scale_mismatch) << " (" << std::lround(mismatch) << " ppm) is the axes' difference";
        out.notes.push_back(o.str());
      }
    }
    for (std::size_t k = 0; k < flat.size(); ++k) {
      double ss = 0;
      std::size_t cnt = 0;
      for (std::size_t i = 0; i < flat_pts.size(); ++i)
        if (flat_pts[i].run == k) {
          ss += res.residual[static_cast<Eigen::Index>(i)] * res.residual[static_cast<Eigen::Index>(i)];
          ++cnt;
        }
      residual_rms[flat_index[k]] = cnt ? std::sqrt(ss / static_cast<double>(cnt)) : nan;
    }
  }
  return residual_rms;
}

}  // namespace guideway::models::dbb::fitting
