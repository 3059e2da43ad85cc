// Workpiece flatness analysis (workpiece_flatness.hpp; Mu 2012): which carriage error shows on a faced part.
#include "models/flatness/workpiece_flatness.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <stdexcept>

#include <Eigen/Core>

#include "formats/profile_files.hpp"
#include "dsp/correlation.hpp"
#include "dsp/series.hpp"
#include "dsp/wavelet.hpp"
#include "models/common/least_squares.hpp"
#include "core/csv_table.hpp"
#include "core/number_format.hpp"

namespace guideway::models::flatness {

namespace {

std::string mm(double m) {
  std::ostringstream s;
  s.precision(6);
  s << m * 1e3;
  return s.str();
}

double required_meta(const formats::Profile& p, const std::string& source, const std::string& key) {
  const auto v = p.meta(key);
  if (!v) throw CsvError(source + ": missing metadata line '# " + key + " = <number>'");
  const auto d = parse_double(*v);
  if (!d || !(*d > 0)) throw CsvError(source + ": metadata '" + key + " = " + v->substr(0, 80) + "' is not a positive number");
  // A machine tool's feed (200 m/min) and spindle speed (100000 /min) at most (docs/formats.md).
  const double max = key == "feed_mm_per_min" ? 200000.0 : 1e5;
  if (*d > max)
    throw CsvError(source + ": metadata '" + key + " = " + *v + "' is outside (0, " + shortest(max) + "]");
  return *d;
}

// Pearson coefficient, 0 when a signal is constant (a perfectly straight carriage has no shape to
// correlate with).
double gamma(const std::vector<double>& a, const std::vector<double>& b) {
  try {
    return dsp::pearson(a, b);
  } catch (const dsp::CorrelationError&) {
    return 0.0;
  }
}

// Least-squares slope of g over the points x (a linear functional of g).
struct SlopeOperator {
  std::vector<double> x;
  double xm = 0.0, sxx = 0.0;
  explicit SlopeOperator(const std::vector<double>& all_x) {
    // A subsample is enough for the slope of a smooth polynomial.
    const std::size_t stride = std::max<std::size_t>(1, all_x.size() / 256);
    for (std::size_t i = 0; i < all_x.size(); i += stride) x.push_back(all_x[i]);
    for (double v : x) xm += v;
    xm /= static_cast<double>(x.size());
    for (double v : x) sxx += (v - xm) * (v - xm);
  }
  template <class G>
  double operator()(const G& g) const {
    double s = 0.0;
    for (double v : x) s += (v - xm) * g(v);
    return sxx > 0 ? s / sxx : 0.0;
  }
};

double std_dev(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  double m = 0.0;
  for (double e : v) m += e;
  m /= static_cast<double>(v.size());
  double s = 0.0;
  for (double e : v) s += (e - m) * (e - m);
  return std::sqrt(s / static_cast<double>(v.size() - 1));
}

}  // namespace

WorkpieceProfile parse_workpiece_profile(std::string_view text, const std::string& source) {
  formats::Profile p;
  try {
    p = formats::parse_profile_csv(text, source);
  } catch (const formats::ProfileFileError& e) {
    throw CsvError(e.what());
  }
  WorkpieceProfile w;
  w.source = source;
  w.feed_m_per_s = required_meta(p, source, "feed_mm_per_min") * 1e-3 / 60.0;
  w.spindle_rpm = required_meta(p, source, "spindle_rpm");
  if (p.x_m.size() < 64)
    throw CsvError(source + ": " + std::to_string(p.x_m.size()) + " points; a profile needs at least 64");
  for (std::size_t i = 0; i < p.z_m.size(); ++i)
    if (!std::isfinite(p.z_m[i]))
      throw CsvError(source + ": point " + std::to_string(i + 1) + " (x = " + mm(p.x_m[i]) +
                       " mm) has no valid height; cut or fill the profile first");
  if (!p.spacing_m())
    throw CsvError(source + ": x is not equally spaced and increasing (the wavelet step needs a uniform grid)");
  w.x_m = std::move(p.x_m);
  w.z_m = std::move(p.z_m);
  return w;
}

WorkpieceProfile read_workpiece_profile(const std::string& path) {
  return parse_workpiece_profile(read_text_file(path), path);
}

namespace {

// Replicates of the straightness polynomial with the traverse's angle noise (parametric bootstrap): the
// spread of the slope they put into z - y2 is the straightness part of u(q).
std::vector<PolynomialFit> straightness_replicas(const AngleTraverse& traverse, const StraightnessOptions& sopt,
                                                 int count) {
  std::vector<PolynomialFit> replicas;
  std::mt19937_64 rng(20120709);
  std::normal_distribution<double> noise(0.0, sopt.instrument.reading_u_rad());
  std::vector<double> a(traverse.pitch_rad.size());
  for (int k = 0; k < count; ++k) {
    for (std::size_t i = 0; i < a.size(); ++i) a[i] = traverse.pitch_rad[i] + noise(rng);
    replicas.push_back(straightness_from_angles(traverse.x_m.front(), traverse.step_m, a, sopt, "vertical").polynomial);
  }
  return replicas;
}

// A profile the analysis can use: as many x as z, inside the traverse, enough points for the levels.
void check_profile(const WorkpieceProfile& p, const AngleTraverse& traverse, double x_end_m, int levels) {
  const double x0 = traverse.x_m.front(), tol = 1e-6 * traverse.step_m;
  const std::size_t n = p.x_m.size();
  if (n != p.z_m.size() || n < 2) throw CsvError(p.source + ": x and z have different lengths or fewer than 2 points");
  if (p.x_m.front() < x0 - tol || p.x_m.back() > x_end_m + tol)
    throw CsvError(p.source + ": profile x from " + mm(p.x_m.front()) + " to " + mm(p.x_m.back()) +
                   " mm leaves the straightness traverse of " + traverse.source + " (" + mm(x0) + " to " + mm(x_end_m) +
                   " mm)");
  if (n < (std::size_t{1} << levels))
    throw CsvError(p.source + ": " + std::to_string(n) + " points are too few for " + std::to_string(levels) +
                   " wavelet levels (need at least " + std::to_string(std::size_t{1} << levels) + ")");
}

// Squareness: what is left of the profile after the straightness y2 is a line c + q y1 (y1 = x - x_start);
// its u widened by an AR(1) view of the residuals (waviness makes neighbouring residuals alike).
void fit_squareness(const WorkpieceProfile& p, const std::vector<double>& y1, const std::vector<double>& y2,
                    ProfileFlatness& pf) {
  const std::size_t n = p.x_m.size();
  Eigen::MatrixXd J(static_cast<Eigen::Index>(n), 2);
  Eigen::VectorXd y(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    const auto ii = static_cast<Eigen::Index>(i);
    J(ii, 0) = 1.0;
    J(ii, 1) = y1[i];
    y(ii) = p.z_m[i] - y2[i];
  }
  const auto fit = solve_lsq(J, y, Eigen::VectorXd(), {"offset_m", "squareness_rad"});
  if (!fit.ok) throw CsvError(p.source + ": squareness fit failed: " + fit.message);
  pf.squareness_rad = fit.x(1);
  pf.residual_rms_m = fit.rms;
  double num = 0.0, den = 0.0;
  for (Eigen::Index i = 0; i + 1 < fit.residual.size(); ++i) num += fit.residual(i) * fit.residual(i + 1);
  for (Eigen::Index i = 0; i < fit.residual.size(); ++i) den += fit.residual(i) * fit.residual(i);
  const double rho = den > 0 ? std::clamp(num / den, 0.0, 0.99) : 0.0;
  pf.residual_lag1_correlation = rho;
  pf.u_fit_rad = fit.u(1) * std::sqrt((1.0 + rho) / (1.0 - rho));
}

// One profile: its wavelet bands (Eq. 18: s1 = A_J), the correlations with Eq. 16's components before and
// after the wavelet step (Eqs. 19, 20), the squareness and its u; `slopes` gets the replicas' slopes.
ProfileFlatness profile_flatness(const WorkpieceProfile& p, const WorkpieceFlatnessResult& r,
                                 const std::vector<PolynomialFit>& replicas, const dsp::Wavelet& wavelet, int levels,
                                 std::vector<double>& slopes) {
  const std::size_t n = p.x_m.size();
  const double x0 = r.straightness_x0_m;
  ProfileFlatness pf;
  pf.source = p.source;
  pf.feed_m_per_s = p.feed_m_per_s;
  pf.spindle_rpm = p.spindle_rpm;
  pf.points = n;
  pf.x_start_m = p.x_m.front();
  pf.x_end_m = p.x_m.back();
  pf.spacing_m = (pf.x_end_m - pf.x_start_m) / static_cast<double>(n - 1);
  pf.peak_to_valley_m = dsp::peak_to_valley(p.z_m);
  const auto bands = dsp::mra(p.z_m, wavelet, dsp::Mode::symmetric, levels);
  for (const auto& b : bands) pf.band_rms_m.push_back(dsp::rms(b));
  const std::vector<double>& x1 = bands.front();
  pf.low_frequency_peak_to_valley_m = dsp::peak_to_valley(x1);

  // Eq. 16's components at the profile's points: y1 (Eq. 15, the shape of a squareness: a line rising
  // towards +x; its size does not change a correlation) and y2 (Eq. 10 from the traverse).
  std::vector<double> y1(n), y2(n);
  for (std::size_t i = 0; i < n; ++i) {
    y1[i] = p.x_m[i] - pf.x_start_m;
    y2[i] = r.straightness(p.x_m[i] - x0);
  }
  pf.correlations.push_back({"squareness", gamma(p.z_m, y1), gamma(x1, y1)});
  pf.correlations.push_back({"straightness", gamma(p.z_m, y2), gamma(x1, y2)});
  const auto& best = std::abs(pf.correlations[0].gamma_after) >= std::abs(pf.correlations[1].gamma_after)
                         ? pf.correlations[0]
                         : pf.correlations[1];
  pf.dominant = best.name;
  pf.impact_factor = best.gamma_after;
  fit_squareness(p, y1, y2, pf);

  const SlopeOperator slope(p.x_m);
  for (const auto& f : replicas) slopes.push_back(slope([&](double x) { return f(x - x0); }));
  pf.u_straightness_rad = std_dev(slopes);
  pf.u_squareness_rad = std::hypot(pf.u_fit_rad, pf.u_straightness_rad);
  const double span = pf.x_end_m - pf.x_start_m;
  pf.squareness_amplitude_m = std::abs(pf.squareness_rad) * span;
  pf.u_squareness_amplitude_m = pf.u_squareness_rad * span;
  return pf;
}

// Combined: weighted mean of the profiles' slopes; the straightness part is common to all.
void combine_profiles(const std::vector<std::vector<double>>& replica_slopes, std::size_t replicas,
                      WorkpieceFlatnessResult& r) {
  std::vector<double> w;
  double sw = 0.0;
  for (const auto& pf : r.profiles) {
    w.push_back(1.0 / std::max(pf.u_fit_rad * pf.u_fit_rad, 1e-40));
    sw += w.back();
  }
  for (std::size_t i = 0; i < r.profiles.size(); ++i) r.squareness_rad += w[i] / sw * r.profiles[i].squareness_rad;
  std::vector<double> combined(replicas, 0.0);
  for (std::size_t k = 0; k < replicas; ++k)
    for (std::size_t i = 0; i < r.profiles.size(); ++i) combined[k] += w[i] / sw * replica_slopes[i][k];
  double u_fit2 = 0.0;
  for (std::size_t i = 0; i < r.profiles.size(); ++i)
    u_fit2 += (w[i] / sw) * (w[i] / sw) * r.profiles[i].u_fit_rad * r.profiles[i].u_fit_rad;
  r.u_squareness_rad = std::hypot(std::sqrt(u_fit2), std_dev(combined));
  r.squareness_amplitude_m = std::abs(r.squareness_rad) * r.travel_m;
  r.u_squareness_amplitude_m = r.u_squareness_rad * r.travel_m;
}

// The dominant error over all profiles: the larger mean |gamma| after the wavelet step.
void dominant_error(WorkpieceFlatnessResult& r) {
  double sq = 0.0, st = 0.0;
  for (const auto& pf : r.profiles) {
    sq += std::abs(pf.correlations[0].gamma_after);
    st += std::abs(pf.correlations[1].gamma_after);
  }
  r.dominant = sq >= st ? "squareness" : "straightness";
  r.impact_factor = (sq >= st ? sq : st) / static_cast<double>(r.profiles.size());
}

// Eq. 21 from a run-out revolution against the profiles' squareness, within 2 u.
RunoutCrossCheck runout_cross_check(const WorkpieceFlatnessResult& r, const RunoutRevolution& runout) {
  RunoutCrossCheck c;
  c.runout = identify_runout(runout);
  c.profile_squareness_rad = std::abs(r.squareness_rad);
  c.u_profile_squareness_rad = r.u_squareness_rad;
  c.difference_rad = c.profile_squareness_rad - c.runout.deflection_rad;
  c.u_difference_rad = std::hypot(r.u_squareness_rad, c.runout.u_deflection_rad);
  c.consistent = std::abs(c.difference_rad) <= 2.0 * c.u_difference_rad;
  return c;
}

}  // namespace

WorkpieceFlatnessResult analyse_workpiece_flatness(const std::vector<WorkpieceProfile>& profiles,
                                                   const AngleTraverse& traverse,
                                                   const std::optional<RunoutRevolution>& runout,
                                                   const WorkpieceFlatnessOptions& options,
                                                   const StraightnessOptions& straightness) {
  if (profiles.empty()) throw std::invalid_argument("workpiece flatness: no profile given");
  if (options.levels < 1) throw std::invalid_argument("workpiece flatness: levels must be >= 1");
  const dsp::Wavelet wavelet(options.wavelet);
  StraightnessOptions sopt = straightness;
  sopt.bootstrap = 0;  // only the polynomial is used here

  WorkpieceFlatnessResult r;
  r.wavelet = options.wavelet;
  r.levels = options.levels;
  r.straightness_source = traverse.source;
  const double x0 = traverse.x_m.front();
  const auto y2_profile = straightness_from_angles(x0, traverse.step_m, traverse.pitch_rad, sopt, "vertical");
  r.straightness = y2_profile.polynomial;
  r.straightness_x0_m = x0;
  r.straightness_x_end_m = y2_profile.x_m.back();
  const std::vector<PolynomialFit> replicas = straightness_replicas(traverse, sopt, options.monte_carlo);

  std::vector<std::vector<double>> replica_slopes;  // [profile][replica]
  for (const auto& p : profiles) {
    check_profile(p, traverse, r.straightness_x_end_m, options.levels);
    std::vector<double> slopes;
    ProfileFlatness pf = profile_flatness(p, r, replicas, wavelet, options.levels, slopes);
    replica_slopes.push_back(std::move(slopes));
    r.travel_m = std::max(r.travel_m, pf.x_end_m - pf.x_start_m);
    r.profiles.push_back(std::move(pf));
  }
  combine_profiles(replica_slopes, replicas.size(), r);
  dominant_error(r);
  if (runout) r.runout_check = runout_cross_check(r, *runout);
  return r;
}

}  // namespace guideway::models::flatness
