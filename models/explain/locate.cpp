// The locate step (locate.hpp): whether a residual is noise, and where it is structured, band by band (db4).
#include "models/explain/locate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

#include <span>
#include "core/number_format.hpp"
#include "dsp/denoise.hpp"
#include "dsp/wavelet.hpp"
#include "models/explain/stats.hpp"

namespace guideway::models::explain {

namespace {

std::string pfmt(double p) { return p < 1e-300 ? std::string("<1e-300") : printf_number("%.2g", p); }

int wavelet_level(std::size_t n) { return std::clamp(dsp::dwt_max_level(n, 8), 1, 10); }

const dsp::Wavelet& db4() {
  static const dsp::Wavelet w("db4");
  return w;
}

std::vector<double> slice(const Eigen::VectorXd& r, std::pair<std::size_t, std::size_t> range) {
  return {r.data() + range.first, r.data() + range.second};
}

std::vector<std::pair<std::size_t, std::size_t>> ranges_of(const std::vector<TestedStretch>& stretches) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (const TestedStretch& s : stretches) out.emplace_back(s.first, s.last);
  return out;
}

// Whether each run is within a stretch the tests decompose (min_run_samples or more).
std::vector<bool> tested_runs(const std::vector<TestedStretch>& stretches, std::size_t runs) {
  std::vector<bool> out(runs, false);
  for (const TestedStretch& s : stretches)
    if (s.last - s.first >= min_run_samples)
      for (std::size_t r = s.first_run; r <= s.last_run && r < runs; ++r) out[r] = true;
  return out;
}

// Median spacing of `where` within runs (domain units per sample).
double spacing(const Problem& p) {
  std::vector<double> d;
  for (std::size_t i = 1; i < p.samples.size(); ++i) {
    if (p.samples[i].run != p.samples[i - 1].run) continue;
    double s = std::abs(p.samples[i].where - p.samples[i - 1].where);
    if (p.domain == "angle_deg") s = std::min(s, std::abs(360.0 - s));
    if (s > 0) d.push_back(s);
  }
  if (d.empty()) return 1.0;
  std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

std::string unit_of(const Problem& p) { return p.domain == "angle_deg" ? "deg" : "mm"; }

std::string band_label(int level, int deepest, bool approx, double step, const std::string& unit) {
  // Detail level j passes periods of about 2^j .. 2^(j+1) samples; the approximation the longer ones.
  if (approx)
    return "A" + std::to_string(deepest) + " (periods > " + printf_number("%.3g", std::ldexp(step, deepest + 1)) + " " +
           unit + ")";
  return "D" + std::to_string(level) + " (periods " + printf_number("%.3g", std::ldexp(step, level)) + "-" +
         printf_number("%.3g", std::ldexp(step, level + 1)) + " " + unit + ")";
}

double wrap_where(const Problem& p, double w) {
  if (p.domain != "angle_deg") return w;
  double a = std::fmod(w, 360.0);
  return a < 0 ? a + 360.0 : a;
}

// Linear interpolation of (x, y) sorted by x at xq (clamped at the ends).
double interp(const std::vector<std::pair<double, double>>& xy, double xq) {
  auto it = std::lower_bound(xy.begin(), xy.end(), std::make_pair(xq, -1e300));
  if (it == xy.begin()) return xy.front().second;
  if (it == xy.end()) return xy.back().second;
  const auto& hi = *it;
  const auto& lo = *(it - 1);
  if (hi.first == lo.first) return hi.second;
  return lo.second + (hi.second - lo.second) * (xq - lo.first) / (hi.first - lo.first);
}

struct Interval {
  double lo, hi, peak;
};

}  // namespace

std::vector<std::pair<std::size_t, std::size_t>> run_ranges(const Problem& problem) {
  std::vector<std::pair<std::size_t, std::size_t>> out(problem.runs.size(), {0, 0});
  std::vector<bool> seen(problem.runs.size(), false);
  for (std::size_t i = 0; i < problem.samples.size(); ++i) {
    const std::size_t r = problem.samples[i].run;
    if (r >= out.size())
      throw std::invalid_argument("explain: sample refers to run " + std::to_string(r) + " of " +
                                  std::to_string(out.size()));
    if (!seen[r]) {
      out[r] = {i, i + 1};
      seen[r] = true;
    } else {
      if (out[r].second != i) throw std::invalid_argument("explain: samples of a run must be contiguous");
      out[r].second = i + 1;
    }
  }
  return out;
}

Location location_of(const Problem& problem, std::size_t first, std::size_t end, double peak_um) {
  const Sample& s0 = problem.samples[first];
  const Sample& s1 = problem.samples[end - 1];
  const RunInfo& ri = problem.runs[s0.run];
  Location loc;
  loc.run = ri.label;
  loc.source = ri.source;
  loc.where = {wrap_where(problem, s0.where), wrap_where(problem, s1.where)};
  loc.t_from_run_start_s = {s0.t_s - ri.start_s, s1.t_s - ri.start_s};
  loc.timed = problem.timed;
  loc.t_machine_s = {problem.clock_origin_s + s0.t_s, problem.clock_origin_s + s1.t_s};
  loc.peak_um = peak_um;
  loc.first_sample = first;
  loc.end_sample = end;
  return loc;
}

std::vector<TestedStretch> tested_stretches(const Problem& problem) {
  const auto ranges = run_ranges(problem);
  const bool paths = problem.path_of_run.size() == ranges.size();
  const auto size = [&](std::size_t k) { return ranges[k].second - ranges[k].first; };
  std::vector<TestedStretch> out;
  for (std::size_t r = 0; r < ranges.size();) {
    // The runs of r's path that follow it sample after sample (a run left with no samples is passed over).
    std::size_t e = r + 1;
    std::optional<std::size_t> first, end;
    if (size(r) > 0) first = ranges[r].first, end = ranges[r].second;
    while (paths && e < ranges.size() && problem.path_of_run[e] == problem.path_of_run[r] &&
           (size(e) == 0 || !end || ranges[e].first == *end)) {
      if (size(e) > 0) {
        if (!first) first = ranges[e].first;
        end = ranges[e].second;
      }
      ++e;
    }
    bool short_run = false;
    for (std::size_t k = r; k < e; ++k) short_run = short_run || (size(k) > 0 && size(k) < min_run_samples);
    if (short_run && e - r > 1 && first) {
      out.push_back({*first, *end, r, e - 1});
    } else {
      for (std::size_t k = r; k < e; ++k) out.push_back({ranges[k].first, ranges[k].second, k, k});
    }
    r = e;
  }
  return out;
}

namespace {

// The flagged bands of x (hard-thresholded details, approximation as is), back in the signal domain.
std::vector<double> band_signal(std::span<const double> x, double sigma, const std::vector<int>& flagged) {
  const int level = wavelet_level(x.size());
  auto c = dsp::wavedec(x, db4(), dsp::Mode::periodization, level);
  const double lambda = dsp::universal_threshold(sigma, x.size());
  for (std::size_t b = 0; b < c.size(); ++b) {
    const int slot = b == 0 ? 0 : level + 1 - static_cast<int>(b);
    const bool keep = std::find(flagged.begin(), flagged.end(), slot) != flagged.end();
    for (double& v : c[b]) {
      if (!keep)
        v = 0.0;
      else if (b > 0)
        v = dsp::apply_threshold(v, lambda, dsp::ThresholdRule::hard);
    }
  }
  auto y = dsp::waverec(c, db4(), dsp::Mode::periodization);
  y.resize(x.size());
  return y;
}

}  // namespace

double visible_energy(const Problem& problem, const Eigen::VectorXd& residual_um, double sigma_um,
                      const std::vector<int>& flagged) {
  if (flagged.empty() || !(sigma_um > 0)) return 0.0;
  double e = 0;
  for (const auto& range : ranges_of(tested_stretches(problem))) {
    const auto x = slice(residual_um, range);
    if (x.size() < min_run_samples) continue;
    for (double v : band_signal(x, sigma_um, flagged)) e += v * v;
  }
  return e;
}

namespace {

// Each run's wavelet bands (runs shorter than min_run_samples have none), the pooled finest details the
// noise is estimated from, and the deepest level.
struct RunBands {
  std::vector<dsp::Coefficients> coeffs;
  std::vector<double> finest;
  int deepest = 0;
};

RunBands decompose_runs(const Eigen::VectorXd& residual_um,
                        const std::vector<std::pair<std::size_t, std::size_t>>& ranges) {
  RunBands out;
  out.coeffs.resize(ranges.size());
  for (std::size_t k = 0; k < ranges.size(); ++k) {
    const auto x = slice(residual_um, ranges[k]);
    if (x.size() < min_run_samples) continue;
    const int level = wavelet_level(x.size());
    out.deepest = std::max(out.deepest, level);
    out.coeffs[k] = dsp::wavedec(x, db4(), dsp::Mode::periodization, level);
    out.finest.insert(out.finest.end(), out.coeffs[k].back().begin(), out.coeffs[k].back().end());
  }
  return out;
}

// The bands whose energy stands out of the noise, and the strongest of them.
struct BandTest {
  std::vector<int> flagged;  // level 0 = the approximation
  std::string dominant;      // the strongest flagged band's label ("" = none)
  double merge_gap = 0;      // its shortest period: lobes closer than that are one feature
  double p = 1.0;            // its p-value
  std::string evidence;
};

// A burst: a short event (a knock's ringing, a glitch) adds too little energy to lift a whole band, but a
// few detail coefficients far above the noise: the largest of each detail band (below the finest, from
// which the noise is estimated) against sigma, Bonferroni over every coefficient tested. A flagged band
// joins the located ones (its structure is shown and placed like the others').
void burst_test(const RunBands& rb, double sigma, double alpha, double step, const std::string& unit, BandTest& out) {
  if (!(sigma > 0)) return;
  std::vector<double> largest(static_cast<std::size_t>(rb.deepest) + 1, 0.0);
  double tested = 0;
  for (const auto& c : rb.coeffs) {
    if (c.empty()) continue;
    const int level = static_cast<int>(c.size()) - 1;
    for (std::size_t b = 1; b < c.size(); ++b) {
      const std::size_t slot = static_cast<std::size_t>(level + 1) - b;
      if (slot < 2) continue;
      for (double v : c[b]) largest[slot] = std::max(largest[slot], std::abs(v));
      tested += static_cast<double>(c[b].size());
    }
  }
  for (std::size_t b = 2; b < largest.size(); ++b) {
    const double z = largest[b] / sigma;
    const double p = std::min(1.0, normal_two_sided(z) * tested);
    if (!(p < alpha / 3)) continue;
    if (std::find(out.flagged.begin(), out.flagged.end(), static_cast<int>(b)) == out.flagged.end())
      out.flagged.push_back(static_cast<int>(b));
    if (p < out.p) {
      out.dominant = band_label(static_cast<int>(b), rb.deepest, false, step, unit);
      out.merge_gap = std::ldexp(step, static_cast<int>(b));
      out.p = p;
      out.evidence = "D" + std::to_string(b) + " has a coefficient " + printf_number("%.3g", z) +
                     " sigma from zero (a burst; p=" + pfmt(p) + " over " + printf_number("%g", tested) +
                     " coefficients)";
    }
  }
}

// Band energy per level (level 0 = approximation), each against the finest one (F-test: the noise level is
// itself estimated from the finest details, so a chi-square with sigma taken as known would be too eager).
BandTest test_bands(const RunBands& rb, double sigma, double alpha, double step, const std::string& unit) {
  struct Band {
    double energy = 0, dof = 0;
  };
  std::vector<Band> bands(static_cast<std::size_t>(rb.deepest) + 1);
  for (const auto& c : rb.coeffs) {
    if (c.empty()) continue;
    const int level = static_cast<int>(c.size()) - 1;
    for (std::size_t b = 0; b < c.size(); ++b) {
      // b = 0: approximation of `level`; b >= 1: detail of level (level + 1 - b).
      const std::size_t slot = b == 0 ? 0 : static_cast<std::size_t>(level + 1) - b;
      for (double v : c[b]) bands[slot].energy += v * v;
      bands[slot].dof += static_cast<double>(c[b].size());
    }
  }
  const Band& finest_band = bands[1];  // slot 1 = D1
  const double ref = finest_band.dof > 0 ? finest_band.energy / finest_band.dof : sigma * sigma;
  BandTest out;
  double best_excess = 0;
  for (std::size_t b = 0; b < bands.size(); ++b) {
    if (b == 1 || bands[b].dof <= 0 || !(ref > 0)) continue;
    const double ratio = bands[b].energy / bands[b].dof / ref;
    const double p = std::min(1.0, f_sf(ratio, bands[b].dof, finest_band.dof) * static_cast<double>(bands.size() - 1));
    const double excess = bands[b].energy - bands[b].dof * ref;
    if (p < alpha / 3) out.flagged.push_back(static_cast<int>(b));
    if (p < alpha / 3 && excess > best_excess) {
      best_excess = excess;
      out.dominant = band_label(static_cast<int>(b), rb.deepest, b == 0, step, unit);
      out.merge_gap = std::ldexp(step, b == 0 ? rb.deepest : static_cast<int>(b));
      out.p = p;
      out.evidence = (b == 0 ? "A" + std::to_string(rb.deepest) : "D" + std::to_string(b)) + " energy " +
                     printf_number("%.3g", ratio) + " x the finest details' (F p=" + pfmt(p) + ")";
    }
  }
  burst_test(rb, sigma, alpha, step, unit, out);
  return out;
}

// Whiteness per run, pooled: runs test z summed, Ljung-Box Q summed.
struct Whiteness {
  double z_runs = 0, p_runs = 1, q = 0, q_dof = 0, p_lb = 1;
};

Whiteness whiteness(const Eigen::VectorXd& residual_um,
                    const std::vector<std::pair<std::size_t, std::size_t>>& ranges) {
  double z_sum = 0;
  std::size_t z_count = 0;
  Whiteness w;
  for (const auto& range : ranges) {
    const auto x = slice(residual_um, range);
    if (x.size() < min_run_samples) continue;
    z_sum += runs_test(x).statistic;
    ++z_count;
    const auto lb = ljung_box(x, std::min<std::size_t>(20, x.size() / 10));
    w.q += lb.statistic;
    w.q_dof += lb.dof;
  }
  w.z_runs = z_count ? z_sum / std::sqrt(static_cast<double>(z_count)) : 0.0;
  w.p_runs = normal_two_sided(w.z_runs);
  w.p_lb = w.q_dof > 0 ? chi2_sf(w.q, w.q_dof) : 1.0;
  return w;
}

// The flagged bands (hard-thresholded) of every run into out.smooth and out.visible_energy; returns their
// largest magnitude.
double smooth_flagged_bands(const Eigen::VectorXd& residual_um,
                            const std::vector<std::pair<std::size_t, std::size_t>>& ranges, double sigma,
                            Located& out) {
  double peak = 0;
  for (const auto& range : ranges) {
    const auto x = slice(residual_um, range);
    if (x.size() < min_run_samples || out.flagged.empty()) continue;
    const auto d = band_signal(x, sigma, out.flagged);
    for (std::size_t i = 0; i < d.size(); ++i) {
      out.smooth[range.first + i] = d[i];
      out.visible_energy += d[i] * d[i];
      peak = std::max(peak, std::abs(d[i]));
    }
  }
  return peak;
}

// The stretches where the smoothed residual reaches half its peak, one sign at a time, within a run.
std::vector<Interval> lobes(const Problem& problem, const std::vector<double>& smooth, double peak) {
  const std::size_t n = problem.samples.size();
  std::vector<Interval> iv;
  for (std::size_t i = 0; i < n;) {
    if (std::abs(smooth[i]) < 0.5 * peak) {
      ++i;
      continue;
    }
    const double sign = smooth[i] > 0 ? 1 : -1;
    Interval cur{wrap_where(problem, problem.samples[i].where), wrap_where(problem, problem.samples[i].where), 0};
    std::size_t j = i;
    for (; j < n && problem.samples[j].run == problem.samples[i].run && smooth[j] * sign >= 0.5 * peak; ++j) {
      const double w = wrap_where(problem, problem.samples[j].where);
      cur.lo = std::min(cur.lo, w);
      cur.hi = std::max(cur.hi, w);
      if (std::abs(smooth[j]) > std::abs(cur.peak)) cur.peak = smooth[j];
    }
    iv.push_back(cur);
    i = j;
  }
  return iv;
}

// Where the structure is: the lobes of the flagged bands, merged when closer than the dominant band's
// shortest period (band-pass ringing), strongest first; or "throughout" when they cover most of the range.
std::string where_structured(const Problem& problem, const std::vector<double>& smooth, double peak, double step,
                             double merge_gap, const std::string& unit,
                             std::vector<std::pair<double, double>>& place_ranges) {
  if (!(peak > 0)) return "below the noise everywhere (no single place stands out)";
  std::vector<Interval> iv = lobes(problem, smooth, peak);
  std::sort(iv.begin(), iv.end(), [](const Interval& a, const Interval& b) { return a.lo < b.lo; });
  std::vector<Interval> merged;
  for (const auto& v : iv) {
    if (!merged.empty() && v.lo <= merged.back().hi + std::max(2 * step, merge_gap)) {
      merged.back().hi = std::max(merged.back().hi, v.hi);
      if (std::abs(v.peak) > std::abs(merged.back().peak)) merged.back().peak = v.peak;
    } else {
      merged.push_back(v);
    }
  }
  double lo = 1e300, hi = -1e300, covered = 0;
  for (const auto& s : problem.samples) {
    lo = std::min(lo, wrap_where(problem, s.where));
    hi = std::max(hi, wrap_where(problem, s.where));
  }
  for (const auto& v : merged) covered += v.hi - v.lo + step;
  if (covered > 0.6 * (hi - lo) || merged.size() > 8)
    return "throughout " + printf_number("%.4g", lo) + ".." + printf_number("%.4g", hi) + " " + unit + " (peak " +
           printf_number("%+.3g", peak) + " um)";
  std::sort(merged.begin(), merged.end(),
            [](const Interval& a, const Interval& b) { return std::abs(a.peak) > std::abs(b.peak); });
  std::string where;
  for (const auto& v : merged) {
    place_ranges.emplace_back(v.lo, v.hi);
    if (!where.empty()) where += ", ";
    where += printf_number("%.4g", v.lo) + ".." + printf_number("%.4g", v.hi) + " " + unit + " (" +
             printf_number("%+.3g", v.peak) + " um)";
  }
  return where;
}

// The same lobes run by run, as sample ranges: merged within a run when closer than `gap` (domain units),
// each in every domain the user can act on; a lobe repeats when another run has one at the same place.
std::vector<Location> run_locations(const Problem& problem, const std::vector<double>& smooth, double peak,
                                    double gap) {
  const std::size_t n = problem.samples.size();
  std::vector<Location> out;
  const auto distance = [&](double a, double b) {
    double d = std::abs(a - b);
    if (problem.domain == "angle_deg") d = std::min(d, 360.0 - d);
    return d;
  };
  for (std::size_t i = 0; i < n;) {
    if (std::abs(smooth[i]) < 0.5 * peak) {
      ++i;
      continue;
    }
    const std::size_t run = problem.samples[i].run;
    std::size_t j = i, last = i;
    double top = 0;
    // Extends over samples of the run below half the peak when the next lobe is within `gap`.
    for (; j < n && problem.samples[j].run == run; ++j) {
      if (std::abs(smooth[j]) >= 0.5 * peak) {
        last = j;
        if (std::abs(smooth[j]) > std::abs(top)) top = smooth[j];
      } else if (distance(problem.samples[j].where, problem.samples[last].where) > gap) {
        break;
      }
    }
    out.push_back(location_of(problem, i, last + 1, top));
    i = last + 1;
  }
  // Same place: the ranges overlap, or come within `gap` (a run in the other direction passes it the other way).
  const auto lo_hi = [](const Location& l) { return std::minmax(l.where.first, l.where.second); };
  for (auto& a : out)
    for (const auto& b : out) {
      if (&a == &b || a.run == b.run) continue;
      const auto [alo, ahi] = lo_hi(a);
      const auto [blo, bhi] = lo_hi(b);
      const bool overlap =
          (alo <= bhi + gap && blo <= ahi + gap) || distance(alo, bhi) <= gap || distance(blo, ahi) <= gap;
      if (overlap && std::find(a.repeats_in.begin(), a.repeats_in.end(), b.run) == a.repeats_in.end())
        a.repeats_in.push_back(b.run);
    }
  return out;
}

// How run i's residual and run j's correlate at the same place: rho and its Fisher z; nullopt when
// either is too short or flat.
struct Correlation {
  double rho, z, slope;  // slope: r_j = slope * r_i
};
std::optional<Correlation> same_place_correlation(const Problem& problem, const Eigen::VectorXd& residual_um,
                                                  std::pair<std::size_t, std::size_t> ri,
                                                  std::pair<std::size_t, std::size_t> rj) {
  std::vector<std::pair<double, double>> xy;
  for (std::size_t q = rj.first; q < rj.second; ++q)
    xy.emplace_back(wrap_where(problem, problem.samples[q].where), residual_um[static_cast<Eigen::Index>(q)]);
  std::sort(xy.begin(), xy.end());
  double sxx = 0, syy = 0, sxy = 0;
  std::size_t m = 0;
  for (std::size_t q = ri.first; q < ri.second; ++q) {
    const double a = residual_um[static_cast<Eigen::Index>(q)];
    const double b = interp(xy, wrap_where(problem, problem.samples[q].where));
    sxx += a * a;
    syy += b * b;
    sxy += a * b;
    ++m;
  }
  if (!(sxx > 0 && syy > 0) || m < 4) return std::nullopt;
  const double rho = sxy / std::sqrt(sxx * syy);
  const double z = std::atanh(std::clamp(rho, -0.999999, 0.999999)) * std::sqrt(static_cast<double>(m) - 3);
  return Correlation{rho, z, sxy / sxx};
}

// Direction and feed: runs of one geometry compared at the same place.
void compare_runs(const Problem& problem, const Eigen::VectorXd& residual_um,
                  const std::vector<std::pair<std::size_t, std::size_t>>& ranges, const std::vector<bool>& tested,
                  const std::string& band, std::vector<Mismatch>& places) {
  for (std::size_t i = 0; i < problem.runs.size(); ++i) {
    for (std::size_t j = i + 1; j < problem.runs.size(); ++j) {
      const auto& ri = problem.runs[i];
      const auto& rj = problem.runs[j];
      if (ri.geometry != rj.geometry) continue;
      const bool dir_pair = ri.direction != rj.direction && ri.feed_mm_per_min == rj.feed_mm_per_min;
      const bool feed_pair = ri.direction == rj.direction && ri.feed_mm_per_min != rj.feed_mm_per_min;
      if (!dir_pair && !feed_pair) continue;
      if (!tested[i] || !tested[j]) continue;
      const auto c = same_place_correlation(problem, residual_um, ranges[i], ranges[j]);
      if (!c || std::abs(c->z) < 4) continue;
      const std::string pair = ri.label + " vs " + rj.label;
      if (dir_pair) {
        places.push_back(
            {"direction",
             pair,
             band,
             "residuals at the same place correlate " + printf_number("%+.2f", c->rho) +
                 " (z=" + printf_number("%.3g", c->z) + "): " +
                 (c->rho < 0 ? "the mismatch flips sign with the direction of motion (velocity-dependent)"
                             : "the mismatch repeats at the same place in both directions (position-dependent)"),
             {},
             {}});
      } else {
        places.push_back({"feed",
                          pair + " (" + printf_number("%g", ri.feed_mm_per_min) + " vs " +
                              printf_number("%g", rj.feed_mm_per_min) + " mm/min)",
                          band,
                          "residuals at the same place correlate " + printf_number("%+.2f", c->rho) +
                              "; the second is " + printf_number("%.3g", c->slope) + " x the first (feed ratio " +
                              printf_number("%.3g", rj.feed_mm_per_min / ri.feed_mm_per_min) + ")",
                          {},
                          {}});
      }
    }
  }
}

// Time: the strongest trend of the residual within a run, when it is clear (z > 5).
void time_trend(const Problem& problem, const Eigen::VectorXd& residual_um,
                const std::vector<std::pair<std::size_t, std::size_t>>& ranges, const std::vector<bool>& tested,
                double sigma, const std::string& band, std::vector<Mismatch>& places) {
  double best_z = 0, best_slope = 0;
  std::string best_run;
  for (std::size_t k = 0; k < ranges.size(); ++k) {
    const auto [a, b] = ranges[k];
    if (!tested[k] || b - a < 3) continue;
    double tm = 0;
    for (std::size_t q = a; q < b; ++q) tm += problem.samples[q].t_s;
    tm /= static_cast<double>(b - a);
    double stt = 0, sty = 0;
    for (std::size_t q = a; q < b; ++q) {
      const double dt = problem.samples[q].t_s - tm;
      stt += dt * dt;
      sty += dt * residual_um[static_cast<Eigen::Index>(q)];
    }
    if (!(stt > 0)) continue;
    const double slope = sty / stt;
    const double z = slope / (sigma / std::sqrt(stt));
    // Runs that trend alike (a drift seen in a forward and a return pass, or by two profiles) are a tie the later
    // run wins: which is larger in their last digits is rounding's, not the data's.
    if (std::abs(z) >= std::abs(best_z) * (1 - 1e-9)) {
      best_z = z;
      best_slope = slope;
      best_run = problem.runs[k].label;
    }
  }
  if (std::abs(best_z) > 5)
    places.push_back({"time_s",
                      best_run,
                      band,
                      "the residual trends " + printf_number("%+.3g", best_slope * 60) +
                          " um/min within the run (z=" + printf_number("%.3g", best_z) + ")",
                      {},
                      {}});
}

}  // namespace

Located locate(const Problem& problem, const Eigen::VectorXd& residual_um, double alpha, double sigma_um) {
  Located out;
  const auto ranges = run_ranges(problem);
  const auto stretches = tested_stretches(problem);
  const auto tested_ranges = ranges_of(stretches);
  const std::vector<bool> tested = tested_runs(stretches, ranges.size());
  out.smooth.assign(problem.samples.size(), 0.0);
  // Bands of every run (a short run's path joined); the noise from the pooled finest details.
  const RunBands rb = decompose_runs(residual_um, tested_ranges);
  if (rb.finest.empty())
    throw std::invalid_argument("explain: every run is shorter than " + std::to_string(min_run_samples) +
                                " samples, and no runs of one path are that many together");
  const double sigma = sigma_um > 0 ? sigma_um : dsp::mad_sigma(rb.finest);
  out.sigma_um = sigma;
  if (!(sigma > 0)) return out;  // an exact fit: nothing to locate
  const double step = spacing(problem);
  const std::string unit = unit_of(problem);
  BandTest bands = test_bands(rb, sigma, alpha, step, unit);
  out.flagged = std::move(bands.flagged);
  const Whiteness w = whiteness(residual_um, tested_ranges);
  out.structured = bands.p < alpha / 3 || w.p_runs < alpha / 3 || w.p_lb < alpha / 3;

  // The places: the flagged bands (hard-thresholded) where they reach half their largest magnitude.
  const double peak = smooth_flagged_bands(residual_um, tested_ranges, sigma, out);
  if (!out.structured) return out;
  std::vector<std::pair<double, double>> place_ranges;
  const std::string where = where_structured(problem, out.smooth, peak, step, bands.merge_gap, unit, place_ranges);
  std::string evidence = bands.evidence;
  const auto add = [&](const std::string& s) { evidence += (evidence.empty() ? "" : "; ") + s; };
  add("runs test z=" + printf_number("%.3g", w.z_runs) + " (p=" + pfmt(w.p_runs) + ")");
  add("Ljung-Box Q=" + printf_number("%.4g", w.q) + " on " + printf_number("%g", w.q_dof) + " dof (p=" + pfmt(w.p_lb) +
      ")");
  add("noise " + printf_number("%.3g", sigma) + " um from the finest details");
  const std::string band = bands.dominant.empty() ? "broadband" : bands.dominant;
  std::vector<Location> locations;
  if (!place_ranges.empty()) locations = run_locations(problem, out.smooth, peak, std::max(2 * step, bands.merge_gap));
  out.places.push_back({problem.domain, where, band, evidence, place_ranges, std::move(locations)});
  compare_runs(problem, residual_um, ranges, tested, band, out.places);
  time_trend(problem, residual_um, ranges, tested, sigma, band, out.places);
  return out;
}

}  // namespace guideway::models::explain
