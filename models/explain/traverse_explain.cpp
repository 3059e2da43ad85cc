// EXPLAIN for straightness traverses and slope profiles (traverse_explain.hpp): a polynomial or per-station base.
#include "models/explain/traverse_explain.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <Eigen/Dense>
#include <unsupported/Eigen/FFT>

#include "core/csv_table.hpp"
#include "core/number_format.hpp"
#include "formats/dabam.hpp"
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/traverse_terms.hpp"
#include "models/explain/locate.hpp"
#include "models/explain/shared_wave.hpp"
#include "models/flatness/instruments.hpp"
#include "models/flatness/straightness.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain {

namespace {

std::string at_line(const std::string& source, std::size_t line) { return source + ":" + std::to_string(line) + ": "; }


// Checks that the readings of `p` are one step apart in one direction (its first step gives it).
void check_stations(const CsvTable& t, const std::vector<std::size_t>& lines, TraversePass& p) {
  if (p.x_m.size() < 2)
    throw CsvError(t.source + ": " + p.source + " has " + std::to_string(p.x_m.size()) +
                   " reading(s); a pass needs at least 2");
  p.direction = p.x_m[1] > p.x_m[0] ? 1 : -1;
  for (std::size_t i = 1; i < p.x_m.size(); ++i) {
    const double dx = (p.x_m[i] - p.x_m[i - 1]) * p.direction;
    if (std::abs(dx - p.step_m) > flatness::station_jitter_tolerance * p.step_m)
      throw CsvError(at_line(t.source, lines[i]) + "x_mm = " + shortest(p.x_m[i] * 1e3) + " is not one step (" +
                     shortest(p.step_m * 1e3) + " mm) " + (p.direction > 0 ? "after" : "before") +
                     " the previous station " + shortest(p.x_m[i - 1] * 1e3) +
                     " (a pass runs one way, a step at a time; a new pass needs a new number in the pass column)");
    if (!p.t_s.empty() && !(p.t_s[i] > p.t_s[i - 1]))
      throw CsvError(at_line(t.source, lines[i]) + "t_s = " + shortest(p.t_s[i]) + " does not increase");
  }
}

}  // namespace

std::vector<TraversePass> parse_traverse_passes(const std::string& text, const std::string& source, std::size_t file,
                                                const flatness::Autocollimator& ac) {
  const CsvTable t = parse_csv_table(text, source);
  const double step_mm = flatness::traverse_step_mm(t);
  const std::size_t cx = t.column("x_mm"), cp = t.column("pitch_arcsec");
  const auto cy = t.find_column("yaw_arcsec"), ct = t.find_column("t_s"), cpass = t.find_column("pass");
  std::vector<TraversePass> out;
  std::vector<std::vector<std::size_t>> lines;
  double pass_number = std::numeric_limits<double>::quiet_NaN();
  for (const auto& row : t.rows) {
    const double n = cpass ? flatness::traverse_pass(t, row, *cpass) : 1.0;
    if (out.empty() || n != pass_number) {
      for (const TraversePass& p : out)
        if (p.source == source + " pass " + shortest(n))
          throw CsvError(at_line(source, row.line) + "pass " + shortest(n) + " again after other passes");
      pass_number = n;
      TraversePass p;
      p.source = cpass ? source + " pass " + shortest(n) : source;
      p.file = file;
      p.step_m = step_mm * 1e-3;
      out.push_back(std::move(p));
      lines.emplace_back();
    }
    TraversePass& p = out.back();
    if (p.x_m.size() == flatness::traverse_max_readings)
      throw CsvError(at_line(source, row.line) + "more than " + std::to_string(flatness::traverse_max_readings) +
                     " readings in a pass (the straightness session's most)");
    p.x_m.push_back(flatness::traverse_x_mm(t, row, cx) * 1e-3);
    p.pitch_rad.push_back(flatness::traverse_angle_rad(t, row, cp));
    if (cy) p.yaw_rad.push_back(flatness::traverse_angle_rad(t, row, *cy));
    if (ct) p.t_s.push_back(flatness::traverse_time_s(t, row, *ct));
    lines.back().push_back(row.line);
  }
  if (out.empty()) throw CsvError(source + ": no readings");
  for (std::size_t k = 0; k < out.size(); ++k) check_stations(t, lines[k], out[k]);
  // One set-up: the file's readings within the instrument's range about their middle.
  std::vector<double> pitch, yaw;
  std::vector<std::size_t> all_lines;
  for (std::size_t k = 0; k < out.size(); ++k) {
    pitch.insert(pitch.end(), out[k].pitch_rad.begin(), out[k].pitch_rad.end());
    yaw.insert(yaw.end(), out[k].yaw_rad.begin(), out[k].yaw_rad.end());
    all_lines.insert(all_lines.end(), lines[k].begin(), lines[k].end());
  }
  flatness::check_instrument_range(pitch, ac, "pitch_arcsec", source, all_lines);
  if (cy) flatness::check_instrument_range(yaw, ac, "yaw_arcsec", source, all_lines);
  return out;
}

std::vector<TraversePass> read_traverse_passes(const std::string& path, std::size_t file,
                                               const flatness::Autocollimator& ac) {
  if (formats::is_dabam_path(path)) return {slope_profile_pass(flatness::read_angle_traverse(path, ac), file)};
  return parse_traverse_passes(read_text_file(path), path, file, ac);
}

std::vector<TraversePass> read_traverse_files(const std::vector<std::string>& paths,
                                              const std::function<flatness::Autocollimator(const std::string&)>& instrument_of) {
  std::vector<TraversePass> out;
  for (std::size_t f = 0; f < paths.size(); ++f) {
    const flatness::Autocollimator ac = instrument_of ? instrument_of(paths[f]) : flatness::default_instrument(paths[f]);
    for (TraversePass& p : read_traverse_passes(paths[f], f, ac)) out.push_back(std::move(p));
  }
  return out;
}

TraversePass slope_profile_pass(const flatness::AngleTraverse& traverse, std::size_t file) {
  TraversePass p;
  p.source = traverse.source;
  p.file = file;
  p.direction = 1;
  p.step_m = traverse.step_m;
  p.x_m = traverse.x_m;
  p.pitch_rad = traverse.pitch_rad;
  p.yaw_rad = traverse.yaw_rad;
  return p;
}

namespace {

struct Layout {
  double x0_m = 0.0, span_m = 0.0, step_m = 0.0;
  std::size_t files = 0;
  bool timed = true, both = false, yaw = true;
};

Layout layout_of(const std::vector<TraversePass>& passes) {
  if (passes.empty()) throw std::invalid_argument("explain: no traverse passes");
  Layout l;
  double lo = 1e300, hi = -1e300, step = 1e300;
  bool fwd = false, back = false;
  std::vector<std::size_t> per_file;
  for (const TraversePass& p : passes) {
    if (p.x_m.size() < 2 || p.pitch_rad.size() != p.x_m.size() || !(p.step_m > 0))
      throw std::invalid_argument(p.source + ": a pass needs 2 or more readings, one pitch each, and a positive step");
    if ((!p.yaw_rad.empty() && p.yaw_rad.size() != p.x_m.size()) || (!p.t_s.empty() && p.t_s.size() != p.x_m.size()))
      throw std::invalid_argument(p.source + ": yaw or times differ in number from the readings");
    for (double x : p.x_m) {
      lo = std::min(lo, x);
      hi = std::max(hi, x + p.step_m);
    }
    step = std::min(step, p.step_m);
    (p.direction > 0 ? fwd : back) = true;
    l.yaw = l.yaw && !p.yaw_rad.empty();
    l.timed = l.timed && !p.t_s.empty();
    if (per_file.size() <= p.file) per_file.resize(p.file + 1, 0);
    ++per_file[p.file];
  }
  // The engine decomposes a run into wavelet bands only from min_run_samples (models/explain/locate.hpp); the
  // passes of one file, the reflector going back and forth, are one path, tested together where a pass is shorter
  // (Problem::path_of_run). One such pass or path at least: said here in a traverse's terms.
  std::size_t longest = 0, most_in_file = 0;
  std::vector<std::size_t> in_file(per_file.size(), 0);
  for (const TraversePass& p : passes) {
    longest = std::max(longest, p.x_m.size());
    in_file[p.file] += p.x_m.size();
  }
  for (std::size_t f = 0; f < per_file.size(); ++f)
    if (per_file[f] >= 2) most_in_file = std::max(most_in_file, in_file[f]);
  if (longest < min_run_samples && most_in_file < min_run_samples) {
    const std::string need = std::to_string(min_run_samples);
    throw std::invalid_argument(
        "explain: the longest pass has " + std::to_string(longest) + " readings" +
        (most_in_file > 0 ? " and the passes of one file " + std::to_string(most_in_file) + " at most"
                          : std::string(" and no other pass of its file")) +
        "; EXPLAIN's structure tests need " + need + " readings or more: a pass of " + need +
        " (over " + shortest(std::round((hi - lo) * 1e6) / 1e3) + " mm: a step of " +
        shortest(std::floor((hi - lo) * 1e3 / static_cast<double>(min_run_samples) * 100) / 100) +
        " mm or less), or passes of one file, forward and return, " + need +
        " readings or more together (their readings are tested together); `guideway identify straightness` "
        "evaluates a pass of any length");
  }
  l.x0_m = lo;
  l.span_m = hi - lo;
  l.step_m = step;
  l.files = per_file.size();
  l.both = fwd && back;
  // In one pass per file, time is a line in x, which the base's slope holds.
  l.timed = l.timed && std::any_of(per_file.begin(), per_file.end(), [](std::size_t n) { return n >= 2; });
  return l;
}

// Mu's Eq. 12 chord form of order k: (p(x + s) - p(x)) / s for p = xi^k, xi = (x - x0) / span.
double chord(double x_m, double step_m, const Layout& l, int k) {
  const double xi = (x_m - l.x0_m) / l.span_m, sigma = step_m / l.span_m;
  return (std::pow(xi + sigma, k) - std::pow(xi, k)) / sigma;
}

// What the passes share at each station (their mean) against the polynomial of order `order`, the strongest wave
// and the yaw's part, in units of the scatter the passes show about each other (each station's readings less a
// constant per direction and a line in time: a rocking and a drift are not scatter; and, once a yaw coupling is found
// (`coupled`), the yaw's part). judged: every station read by two passes or more, in one file, with scatter left to
// estimate.
struct SharedGeometry {
  bool judged = false;
  std::size_t stations = 0;
  double chi2 = 0.0, dof = 0.0;
};

// The passes' scatter (variance per reading) from r, each reading less its station's mean, less the columns d (a
// constant per direction, a line in time and, once a yaw coupling is found, the yaw), robustly: the median absolute
// scatter (as a normal's, 1.4826 MAD, scaled by the readings per dof), the columns fitted again without the readings
// beyond 4 of it, which are then `apart`. A transient in a few readings (the return settling after the reversal, a
// knock) is not the passes' scatter, nor the geometry they share: counted in a sum of squares, and tilting the line in
// time, it made the scatter 6 times what it is and hid a real surface's shared part (dabam-053: the polynomial kept,
// the rocking refused by the share rule).
struct Scatter {
  double sigma2 = 0.0;
  std::vector<bool> apart;  // per reading
};
Scatter robust_scatter(const Eigen::VectorXd& r, const Eigen::MatrixXd& d, double dof) {
  const auto robust_sigma = [](const Eigen::VectorXd& e) {
    std::vector<double> magnitude(e.data(), e.data() + e.size());
    for (double& v : magnitude) v = std::abs(v);
    std::nth_element(magnitude.begin(), magnitude.begin() + static_cast<std::ptrdiff_t>(magnitude.size() / 2),
                     magnitude.end());
    return 1.4826 * magnitude[magnitude.size() / 2];
  };
  Eigen::VectorXd e = r - d * d.colPivHouseholderQr().solve(r);
  const double first = robust_sigma(e);
  std::vector<Eigen::Index> inside;
  for (Eigen::Index i = 0; i < r.size(); ++i)
    if (std::abs(e[i]) <= 4 * first) inside.push_back(i);
  if (2 * static_cast<Eigen::Index>(inside.size()) > r.size()) {
    const Eigen::MatrixXd di = d(inside, Eigen::all);
    const Eigen::VectorXd ri = r(inside);
    e = r - d * di.colPivHouseholderQr().solve(ri);
  }
  Scatter out;
  const double sigma = robust_sigma(e);
  out.sigma2 = std::max(sigma * sigma * static_cast<double>(r.size()) / dof, 1e-12);
  out.apart.resize(static_cast<std::size_t>(r.size()));
  for (Eigen::Index i = 0; i < r.size(); ++i)
    out.apart[static_cast<std::size_t>(i)] = sigma > 0 && std::abs(e[i]) > 4 * sigma;
  return out;
}

// The strongest line of the periodogram of v (the station means' leftovers, weighted, at the stations x) over the
// frequencies lo, lo + df, .. hi. Where the span is S steps those are the bins (6 + i) / (4 span) of a DFT of 4 S
// points (the stations sit on the grid x0 + s step): one FFT, the same sums in another order, used where the
// frequencies are within 1e-3 of a bin (a real profile's positions written to 1 nm); else the direct sum, the
// stations times the frequencies (9,230 stations: 2 s of CPU a call).
double strongest_line(const Eigen::VectorXd& v, const Eigen::VectorXd& x, const Layout& l, double lo, double hi,
                      double df) {
  const auto stations = static_cast<std::size_t>(v.size());
  std::vector<std::complex<double>> spectrum;
  const double bins = (hi - lo) / df + 6;  // the highest frequency's bin
  if (bins * std::abs(static_cast<double>(stations) * l.step_m / l.span_m - 1.0) <= 1e-3) {
    std::vector<double> padded(4 * stations, 0.0);
    for (std::size_t k = 0; k < stations; ++k) padded[k] = v[static_cast<Eigen::Index>(k)];
    Eigen::FFT<double> fft;
    fft.SetFlag(Eigen::FFT<double>::HalfSpectrum);
    fft.fwd(spectrum, padded);
  }
  double best_f = lo, best_power = -1.0;
  std::size_t bin = 6;
  for (double f = lo; f <= hi; f += df, ++bin) {
    double power = 0.0;
    if (bin < spectrum.size()) {
      power = std::norm(spectrum[bin]);
    } else {
      double c = 0.0, sn = 0.0;
      for (Eigen::Index k = 0; k < v.size(); ++k) {
        const double th = 2 * std::numbers::pi * f * (x[k] + l.step_m / 2);
        c += v[k] * std::cos(th);
        sn += v[k] * std::sin(th);
      }
      power = c * c + sn * sn;
    }
    if (power > best_power) {
      best_power = power;
      best_f = f;
    }
  }
  return best_f;
}

SharedGeometry shared_geometry(const std::vector<TraversePass>& passes, const Layout& l, const Eigen::VectorXd& y,
                               const std::vector<std::size_t>& stations, int order, bool coupled) {
  SharedGeometry out;
  if (stations.empty() || l.files != 1) return out;
  const std::size_t S = *std::max_element(stations.begin(), stations.end()) + 1;
  out.stations = S;
  const auto n = y.size();
  std::vector<double> count(S, 0.0), mean(S, 0.0), dir(S, 0.0), time(S, 0.0), yaw(S, 0.0);
  std::vector<double> dir_of(static_cast<std::size_t>(n)), t_of(static_cast<std::size_t>(n)),
      yaw_of(static_cast<std::size_t>(n), 0.0);
  Eigen::Index row = 0;
  for (const TraversePass& p : passes)
    for (std::size_t i = 0; i < p.x_m.size(); ++i, ++row) {
      const std::size_t s = stations[static_cast<std::size_t>(row)];
      dir_of[static_cast<std::size_t>(row)] = p.direction;
      t_of[static_cast<std::size_t>(row)] = l.timed ? p.t_s[i] : 0.0;
      count[s] += 1;
      mean[s] += y[row];
      dir[s] += p.direction;
      time[s] += t_of[static_cast<std::size_t>(row)];
      if (l.yaw) yaw_of[static_cast<std::size_t>(row)] = p.yaw_rad[i] * 1e6;
      yaw[s] += yaw_of[static_cast<std::size_t>(row)];
    }
  for (std::size_t s = 0; s < S; ++s) {
    if (count[s] < 2) return out;
    mean[s] /= count[s];
    dir[s] /= count[s];
    time[s] /= count[s];
    yaw[s] /= count[s];
  }
  // The scatter: each reading about its station's mean, less a constant per direction, a line in time and, once a
  // yaw coupling is found, the yaw's part. A yaw the passes take differently at a station (its repeatability) couples
  // that difference into the pitch: counted as scatter, it hid a real surface's shared part (dabam-031 and 053 with a
  // yaw coupling of sin 3 deg: the polynomial kept, the surface's leftovers read as a pitch wave beside the coupling).
  // Before the coupling is found the yaw's disagreement is not taken out: fitted to a yaw that couples nothing, the
  // column moved the robust scatter enough to turn a synthetic traverse's base (traverse_few_stations, seed 3).
  const bool yaw_out = l.yaw && coupled;
  const Eigen::Index columns = yaw_out ? 3 : 2;
  Eigen::MatrixXd d(n, columns);
  Eigen::VectorXd r(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const std::size_t s = stations[static_cast<std::size_t>(i)];
    r[i] = y[i] - mean[s];
    d(i, 0) = dir_of[static_cast<std::size_t>(i)] - dir[s];
    d(i, 1) = t_of[static_cast<std::size_t>(i)] - time[s];
    if (yaw_out) d(i, 2) = yaw_of[static_cast<std::size_t>(i)] - yaw[s];
  }
  const double dof_scatter = static_cast<double>(n) - static_cast<double>(S) - static_cast<double>(columns);
  if (dof_scatter < 8) return out;
  const Scatter scatter = robust_scatter(r, d, dof_scatter);
  const double sigma2 = scatter.sigma2;
  // The shared part: station means, weighted by their readings, against the polynomial, the yaw and one wave; not
  // at a station where a reading stands apart from the others (a transient of one pass is not shared geometry).
  std::vector<bool> judged(S, true);
  for (Eigen::Index i = 0; i < n; ++i)
    if (scatter.apart[static_cast<std::size_t>(i)]) judged[stations[static_cast<std::size_t>(i)]] = false;
  const auto S_i = static_cast<Eigen::Index>(S);
  Eigen::VectorXd w(S_i), m(S_i), x(S_i);
  for (std::size_t s = 0; s < S; ++s) {
    const auto k = static_cast<Eigen::Index>(s);
    w[k] = judged[s] ? std::sqrt(count[s]) : 0.0;
    m[k] = mean[s] * w[k];
    x[k] = l.x0_m + l.step_m * static_cast<double>(s);
  }
  const Eigen::Index q = order + (l.yaw ? 1 : 0);
  Eigen::MatrixXd a(S_i, q + 2);
  for (Eigen::Index k = 0; k < S_i; ++k) {
    for (int j = 1; j <= order; ++j) a(k, j - 1) = chord(x[k], l.step_m, l, j) * w[k];
    if (l.yaw) a(k, order) = yaw[static_cast<std::size_t>(k)] * w[k];
  }
  const auto rss_at = [&](double f) {
    for (Eigen::Index k = 0; k < S_i; ++k) {
      a(k, q) = std::sin(2 * std::numbers::pi * f * (x[k] + l.step_m / 2)) * w[k];
      a(k, q + 1) = std::cos(2 * std::numbers::pi * f * (x[k] + l.step_m / 2)) * w[k];
    }
    return (m - a * a.colPivHouseholderQr().solve(m)).squaredNorm();
  };
  // The wave: the periodogram's strongest line over the pitch wave's range (1.5 cycles over the span to 2.5 steps
  // a cycle), of what the polynomial and the yaw leave, then refined between its neighbours.
  const Eigen::MatrixXd base_part = a.leftCols(q);
  const Eigen::VectorXd left = m - base_part * base_part.colPivHouseholderQr().solve(m);
  const double lo = 1.5 / l.span_m, hi = 1.0 / (2.5 * l.step_m), df = 0.25 / l.span_m;
  const double best_f = strongest_line(left.cwiseProduct(w), x, l, lo, hi, df);
  double f_lo = best_f - df, f_hi = best_f + df;
  const double g = (std::sqrt(5.0) - 1) / 2;
  double f1 = f_hi - g * (f_hi - f_lo), f2 = f_lo + g * (f_hi - f_lo), r1 = rss_at(f1), r2 = rss_at(f2);
  for (int it = 0; it < 30; ++it) {
    if (r1 < r2) {
      f_hi = f2, f2 = f1, r2 = r1, f1 = f_hi - g * (f_hi - f_lo), r1 = rss_at(f1);
    } else {
      f_lo = f1, f1 = f2, r1 = r2, f2 = f_lo + g * (f_hi - f_lo), r2 = rss_at(f2);
    }
  }
  const double shared_rss = std::min({r1, r2, rss_at(best_f)});
  out.dof = static_cast<double>(std::count(judged.begin(), judged.end(), true)) - static_cast<double>(q) - 3.0;
  if (out.dof < 8) return out;
  out.chi2 = shared_rss / sigma2;
  out.judged = true;
  return out;
}

// The identification's polynomial (order by BIC, N ln(RSS/N) + q ln N, up to 8 and fewer than the stations
// of a pass) through every pass at once, and an offset for each file after the first. `beside`: the terms of
// effects found that are not a function of the station (explain_traverses), fitted beside each order: they count
// alike in every order's BIC and are not part of the base (the engine judges them again as candidates); `found`
// names them; `coupled`: a yaw coupling is among them (shared_geometry).
Block base_block(const std::vector<TraversePass>& passes, const Layout& l, const Eigen::VectorXd& y,
                 const std::vector<std::size_t>& stations, const Eigen::MatrixXd& effects_beside,
                 const std::string& found, bool coupled, std::string& note, bool& per_station) {
  const auto n = y.size();
  std::size_t fewest = passes.front().x_m.size();
  for (const TraversePass& p : passes) fewest = std::min(fewest, p.x_m.size());
  const int highest = std::clamp(static_cast<int>(fewest) - 2, 1, 8);
  const auto design = [&](int order) {
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, order + static_cast<Eigen::Index>(l.files) - 1);
    Eigen::Index row = 0;
    for (const TraversePass& p : passes)
      for (double x : p.x_m) {
        for (int k = 1; k <= order; ++k) a(row, k - 1) = chord(x, p.step_m, l, k);
        if (p.file > 0) a(row, order + static_cast<Eigen::Index>(p.file) - 1) = 1.0;
        ++row;
      }
    return a;
  };
  const Eigen::Index beside = effects_beside.rows() == n ? effects_beside.cols() : 0;
  const double dn = static_cast<double>(n);
  int best = 1;
  double best_bic = std::numeric_limits<double>::infinity();
  for (int order = 1; order <= highest; ++order) {
    Eigen::MatrixXd a(n, design(order).cols() + beside);
    a.leftCols(a.cols() - beside) = design(order);
    if (beside > 0) a.rightCols(beside) = effects_beside;
    const double rss = (y - a * a.colPivHouseholderQr().solve(y)).squaredNorm();
    const double bic = dn * std::log(std::max(rss, dn * 1e-12) / dn) + static_cast<double>(a.cols()) * std::log(dn);
    if (bic < best_bic - 1e-9) {
      best_bic = bic;
      best = order;
    }
  }
  Block b;
  // Where every station is read by two passes or more and what they share is not the polynomial (with, at most, a
  // pitch wave and the yaw's part: the shared candidates), the geometry is what the passes share: a term per
  // station, and the candidates are judged on what the passes disagree on (a real surface is not a polynomial).
  // The terms are fitted out of the readings, not given as columns (Problem::station_means_absorbed): as columns the
  // engine factored them per fold, the stations squared times the readings (481 stations as two passes: 5.5 s of
  // CPU; 9,230 could not be held), fitted out they cost a pass over the readings.
  const auto beyond = [](const SharedGeometry& g) { return g.judged && g.chi2 > g.dof + 3.09 * std::sqrt(2.0 * g.dof); };
  const int bic_order = best;
  SharedGeometry shared = shared_geometry(passes, l, y, stations, best, coupled);
  // The BIC's order was chosen against a residual a shared wave is part of (a rack's wave of 2.4 urad hides a bow
  // of 1 urad from it, as a drift does): before the geometry is called "not a polynomial", the higher orders, each
  // with the wave and the yaw's part; the lowest that leaves what the passes share within their scatter is the base.
  if (beyond(shared))
    for (int order = best + 1; order <= highest; ++order)
      if (const SharedGeometry higher = shared_geometry(passes, l, y, stations, order, coupled);
          higher.judged && !beyond(higher)) {
        best = order;
        shared = higher;
        break;
      }
  per_station = beyond(shared);
  if (per_station) {
    b.columns = Eigen::MatrixXd(n, 0);
  } else {
    b.columns = design(best);
    for (int k = 1; k <= best; ++k) b.names.push_back("straightness_b" + std::to_string(k) + "_urad");
    for (std::size_t f = 1; f < l.files; ++f) b.names.push_back("file" + std::to_string(f + 1) + ".offset_urad");
  }
  note = per_station ? "base: a term per station (" + std::to_string(shared.stations) +
                           " stations, each read by two passes or more): the geometry the passes share, which the "
                           "polynomial of order " + std::to_string(best) + " with a pitch wave" +
                           (l.yaw ? " and the yaw's part" : "") + " leaves " +
                           printf_number("%.1f", std::sqrt(shared.chi2 / shared.dof)) +
                           " times the passes' own scatter; fitted out of the readings (each less its station's "
                           "mean), the held-out folds holding whole stations; a wave the passes share is then "
                           "geometry, judged against the geometry's own spectrum"
                     : "base: the straightness polynomial of order " + std::to_string(best) + " (BIC, 1.." +
                           std::to_string(highest) +
                           (beside > 0 ? ", chosen with " + found + " fitted beside it" : std::string()) +
                           (best > bic_order ? "; raised from " + std::to_string(bic_order) +
                                                   ", with which what the passes share was more than a wave" +
                                                   (l.yaw ? " and the yaw's part" : "") + " beyond it"
                                             : std::string()) +
                           ") common to every pass" + (l.files > 1 ? ", an offset per file after the first" : "");
  return b;
}

}  // namespace

namespace {

Problem traverse_problem_beside(const std::vector<TraversePass>& passes, const Eigen::MatrixXd& beside,
                                const std::string& found, bool coupled) {
  const Layout l = layout_of(passes);
  Problem p;
  p.model = "traverse";
  p.domain = "position_mm";
  p.timed = l.timed;
  std::vector<effects::Tp> g;
  std::vector<double> file_t0(l.files, std::numeric_limits<double>::quiet_NaN());
  for (const TraversePass& pass : passes)
    if (l.timed)
      file_t0[pass.file] =
          std::isnan(file_t0[pass.file]) ? pass.t_s.front() : std::min(file_t0[pass.file], pass.t_s.front());
  std::size_t index = 0;
  for (std::size_t k = 0; k < passes.size(); ++k) {
    const TraversePass& pass = passes[k];
    const double t0 = l.timed ? file_t0[pass.file] : 0.0;
    for (std::size_t i = 0; i < pass.x_m.size(); ++i, ++index) {
      // Without times, each reading counts one: the locations then speak of readings (Problem::timed).
      const double t = l.timed ? pass.t_s[i] - t0 : static_cast<double>(index);
      g.push_back({k, pass.x_m[i] + pass.step_m / 2, t, pass.direction, l.yaw ? pass.yaw_rad[i] * 1e6 : 0.0});
      if (!std::isfinite(pass.pitch_rad[i])) throw std::invalid_argument(pass.source + ": a reading is not finite");
      p.samples.push_back({k, std::tan(pass.pitch_rad[i]) * 1e6, pass.x_m[i] * 1e3, t});
      p.station_of.push_back(static_cast<std::size_t>(std::max(0.0, std::round((pass.x_m[i] - l.x0_m) / l.step_m))));
    }
    p.path_of_run.push_back(pass.file);
    p.runs.push_back({"pass" + std::to_string(k + 1) + (pass.direction > 0 ? " (+)" : " (-)"), pass.direction, 0.0,
                      "traverse", pass.source, g[index - pass.x_m.size()].t_s});
  }
  Eigen::VectorXd y(static_cast<Eigen::Index>(p.samples.size()));
  for (std::size_t i = 0; i < p.samples.size(); ++i) y[static_cast<Eigen::Index>(i)] = p.samples[i].y_um;
  std::string base_note;
  bool per_station = false;
  p.base = base_block(passes, l, y, p.station_of, beside, found, coupled, base_note, per_station);
  const effects::TraverseTerms terms{g, l.both, l.timed, l.yaw, l.span_m, l.step_m};
  p.candidates = effects::traverse_candidates(terms);
  if (per_station) absorb_station_means(p);
  // A term's size across every pass: a rocking is constant along each pass, +r one way and -r the other.
  p.contribution_of = [](const Eigen::VectorXd& term) { return term.maxCoeff() - term.minCoeff(); };
  p.notes.push_back("what is explained: the pitch readings as slopes, in urad (= um/m); the report's um are urad");
  p.notes.push_back(base_note);
  if (!l.both) p.notes.push_back("passes one way only: an angle that flips with the direction of travel is not seen");
  if (!l.timed)
    p.notes.push_back("no pass back or repeat with times (t_s): a drift in time is a slope in x, part of the base");
  return p;
}

// Whether a term's column is a function of the station: the same at every reading of a station (a pitch wave) --
// not a drift or a rocking, which differ between the passes over it.
bool function_of_station(const std::vector<double>& column, const std::vector<std::size_t>& station_of) {
  const std::size_t S = station_of.empty() ? 0 : *std::max_element(station_of.begin(), station_of.end()) + 1;
  std::vector<double> sum(S, 0.0), count(S, 0.0);
  double mean = 0.0;
  for (std::size_t i = 0; i < column.size(); ++i) {
    sum[station_of[i]] += column[i];
    count[station_of[i]] += 1;
    mean += column[i] / static_cast<double>(column.size());
  }
  double within = 0.0, total = 0.0;
  for (std::size_t i = 0; i < column.size(); ++i) {
    within += std::pow(column[i] - sum[station_of[i]] / count[station_of[i]], 2);
    total += std::pow(column[i] - mean, 2);
  }
  return within <= 1e-12 * total;
}

bool found_in(const Report& report, const std::string& effect) {
  return std::any_of(report.findings.begin(), report.findings.end(),
                     [&](const Finding& held) { return held.effect == effect; });
}

// Where the base is a term per station, a pitch wave the passes share is geometry: the engine's tests, of what the
// passes disagree on, hold nothing of it. It is judged against the geometry (shared_wave.hpp): a line of the station
// means standing above their own spectrum is a finding, appended with its size and u, its BIC and p those of that
// test (its columns kept when asked); else pitch_wave's verdict in `considered` says what the line stood at. A yaw
// coupling found puts the yaw's shape in the pitch, in the geometry too (the yaw the passes share): the station means'
// part along the yaw's station means (fitted with a constant and a line) is taken out first. A carriage's yaw wave
// read through the head's roll was reported as a pitch wave beside the coupling; with the coupling's own estimate
// taken out instead (from what the passes disagree on, known to its u), its error, 2.7 u on dabam-034, left a wave
// of the yaw's shape standing above the spectrum. What lies along that shape cannot be told from the coupling.
void judge_shared_wave(const std::vector<TraversePass>& passes, const Problem& problem, const ExplainOptions& options,
                       Report& report) {
  const auto candidate = std::find_if(problem.candidates.begin(), problem.candidates.end(),
                                      [](const Candidate& c) { return c.effect == "pitch_wave"; });
  if (!problem.station_means_absorbed || candidate == problem.candidates.end() || found_in(report, "pitch_wave"))
    return;
  const Layout l = layout_of(passes);
  const bool coupled = found_in(report, "yaw_coupling");
  const std::size_t stations = *std::max_element(problem.station_of.begin(), problem.station_of.end()) + 1;
  std::vector<double> mean(stations, 0.0), yaw(stations, 0.0), count(stations, 0.0);
  std::size_t row = 0;
  for (const TraversePass& p : passes)
    for (std::size_t i = 0; i < p.pitch_rad.size(); ++i) {
      const std::size_t s = problem.station_of[row++];
      mean[s] += std::tan(p.pitch_rad[i]) * 1e6;
      if (coupled) yaw[s] += p.yaw_rad[i] * 1e6;
      count[s] += 1;
    }
  for (std::size_t s = 0; s < stations; ++s) {
    if (count[s] == 0) return;
    mean[s] /= count[s];
    yaw[s] /= count[s];
  }
  if (coupled) {
    const auto S = static_cast<Eigen::Index>(stations);
    Eigen::MatrixXd a(S, 3);
    for (Eigen::Index s = 0; s < S; ++s) a.row(s) << 1.0, static_cast<double>(s), yaw[static_cast<std::size_t>(s)];
    Eigen::Map<Eigen::VectorXd> m(mean.data(), S);
    m -= a.col(2) * a.colPivHouseholderQr().solve(m)[2];
  }
  const SharedWave w = shared_wave(mean, l.x0_m, l.step_m, options.alpha);
  if (!w.judged) return;
  const std::string line = "at " + printf_number("%.4g", w.period_m * 1e3) + " mm, stands " +
                           printf_number("%.1f", w.ratio) + " times above the geometry's own spectrum there and " +
                           printf_number("%.1f", w.local_ratio) + " times above its neighbours (a line needs more "
                           "than " + printf_number("%.1f", w.needed) + " in both: alpha " +
                           printf_number("%g", options.alpha) + " over the " + std::to_string(w.lines) +
                           " lines searched)";
  // What the traverse resolves of the straightness: the station means' scatter (the final fit's, per reading, over
  // the readings a station has) integrated over the stations. A line whose height A P / 2 pi is below it moves the
  // straightness by less than the passes can tell: a real scan's own short period (dabam-073: 0.002" every 0.46 mm,
  // 0.8 pm, against 0.13 nm) is no finding for the machine.
  const double n = static_cast<double>(problem.station_of.size()), per_station = n / static_cast<double>(stations);
  const double resolved_um = report.final_fit.rms_um * std::sqrt(n / std::max(n - static_cast<double>(stations), 1.0) /
                                                                 per_station) *
                             l.step_m * std::sqrt(static_cast<double>(stations));
  const double height_um = std::hypot(w.sin_arcsec, w.cos_arcsec) * effects::urad_per_arcsec * w.period_m /
                           (2 * std::numbers::pi);
  const auto considered = std::find_if(report.considered.begin(), report.considered.end(),
                                       [](const Considered& c) { return c.effect == "pitch_wave"; });
  if (!w.found || height_um <= resolved_um) {
    if (considered != report.considered.end())
      considered->verdict =
          "a wave the passes share is in the base's term per station; the geometry's strongest line, " + line +
          (w.found ? ", but its height, " + printf_number("%.3g", height_um * 1e3) + " nm, is below the " +
                         printf_number("%.3g", resolved_um * 1e3) + " nm of straightness the passes resolve"
                   : std::string());
    return;
  }
  if (considered != report.considered.end()) report.considered.erase(considered);
  Finding f;
  f.effect = "pitch_wave";
  f.why = candidate->why;
  Eigen::VectorXd coef(2);
  coef << w.sin_arcsec, w.cos_arcsec;
  Eigen::MatrixXd cov(2, 2);
  cov << w.var_sin, w.cov_sin_cos, w.cov_sin_cos, w.var_cos;
  f.parameters = amp_phase(results::name(results::pitch_wave), results::name(results::pitch_wave_phase), coef, cov);
  f.parameters.push_back({results::name(results::pitch_wave_period), w.period_m * 1e3,
                          std::numeric_limits<double>::quiet_NaN()});
  // Its chi2 against the spectrum is twice the ratio; 2 coefficients and the searched period.
  f.delta_bic = -2 * w.ratio + 3 * std::log(static_cast<double>(stations));
  f.p_value = std::min(1.0, static_cast<double>(w.lines) * std::exp(-w.ratio));
  f.rms_um_after = report.final_fit.rms_um;  // the base held it: the readings' fit is the same
  f.heldout_rms_um_after = report.final_fit.heldout_rms_um;
  f.share = std::numeric_limits<double>::quiet_NaN();
  f.contribution_um = 2 * std::hypot(w.sin_arcsec, w.cos_arcsec) * effects::urad_per_arcsec;
  if (options.keep_columns) {
    f.column_names = {results::name(results::pitch_wave_sin), results::name(results::pitch_wave_cos)};
    f.columns_um.assign(2, {});
    for (const TraversePass& p : passes)
      for (const double x : p.x_m) {
        const double th = 2 * std::numbers::pi * (x + p.step_m / 2) / w.period_m;
        f.columns_um[0].push_back(std::sin(th) * effects::urad_per_arcsec);
        f.columns_um[1].push_back(std::cos(th) * effects::urad_per_arcsec);
      }
  }
  report.findings.push_back(std::move(f));
  if (!report.curve_steps.empty()) {  // a step per finding: the same residual, the base having held the wave
    ResidualStep step = report.curve_steps.back();
    step.label = "+ pitch_wave";
    report.curve_steps.push_back(std::move(step));
  }
  report.notes.push_back("pitch_wave: the geometry the passes share, which the base's term per station holds, has a "
                         "line that, " + line + "; its size and u are a sine's fitted to the station means beside a "
                         "constant and a line, that spectrum as their noise, and its BIC and p are that test's (the "
                         "passes' disagreement, which the F-test and the held-out RMS judge, holds nothing of it)");
}

}  // namespace

Problem traverse_problem(const std::vector<TraversePass>& passes) {
  return traverse_problem_beside(passes, {}, "", false);
}

// The base's order is chosen by the BIC before anything is found, against a residual that holds the effects: a drift
// or a rocking tilts each pass, and a drift of 0.25"/min over four passes hides a bow of 1 urad from the BIC (order
// 1, the bow then read as a 400 mm pitch wave, or the passes' shared part as a term per station, a real wave with
// it). Once such effects are found, the order is chosen again with their terms fitted beside it; where that changes
// the base, the problem is explained again with it (issue 41 item 6). Effects that are a function of the station (a
// pitch wave) are not fitted beside: they would take the geometry's place.
Report explain_traverses(const std::vector<TraversePass>& passes, const ExplainOptions& options) {
  const Problem first = traverse_problem(passes);
  ExplainOptions with_columns = options;
  with_columns.keep_columns = true;
  Report report = explain(first, with_columns);
  std::vector<const std::vector<double>*> columns;
  std::string found, first_found;
  for (const Finding& f : report.findings) {
    first_found += (first_found.empty() ? "" : ", ") + f.effect;
    bool tilts = false;
    for (const auto& c : f.columns_um)
      if (c.size() == first.samples.size() && !function_of_station(c, first.station_of)) {
        columns.push_back(&c);
        tilts = true;
      }
    if (tilts) found += (found.empty() ? "" : " and ") + f.effect;
  }
  const auto without_columns = [&](Report r) {
    if (!options.keep_columns)
      for (Finding& f : r.findings) {
        f.columns_um.clear();
        f.column_names.clear();
      }
    return r;
  };
  const auto with_wave = [&](const Problem& problem, Report r) {
    judge_shared_wave(passes, problem, options, r);
    return r;
  };
  if (columns.empty()) return with_wave(first, without_columns(std::move(report)));
  Eigen::MatrixXd beside(static_cast<Eigen::Index>(first.samples.size()), static_cast<Eigen::Index>(columns.size()));
  for (std::size_t k = 0; k < columns.size(); ++k)
    beside.col(static_cast<Eigen::Index>(k)) =
        Eigen::Map<const Eigen::VectorXd>(columns[k]->data(), static_cast<Eigen::Index>(columns[k]->size()));
  Problem again = traverse_problem_beside(passes, beside, found, found_in(report, "yaw_coupling"));
  if (again.base.names == first.base.names) return with_wave(first, without_columns(std::move(report)));
  std::string before;
  for (const std::string& n : first.notes)
    if (n.rfind("base: ", 0) == 0) before = n.substr(6);
  again.notes.push_back("the base was chosen again once " + found +
                        " was found (it tilts each pass, and the base had been chosen against it): before, " + before +
                        ", and the findings were " + first_found);
  return with_wave(again, explain(again, options));
}

}  // namespace guideway::models::explain
