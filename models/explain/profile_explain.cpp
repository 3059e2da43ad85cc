// EXPLAIN for faced-workpiece profiles (profile_explain.hpp): Mu's carriage straightness as the base.
#include "models/explain/profile_explain.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "core/number_format.hpp"
#include "formats/profile_files.hpp"
#include "models/common/least_squares.hpp"
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/profile_terms.hpp"

namespace guideway::models::explain {

namespace {

double meta_number(const formats::Profile& p, const std::string& path, const std::string& key, double fallback,
                   bool required) {
  const auto v = p.meta(key);
  if (!v) {
    if (required) throw std::invalid_argument(path + ": metadata '" + key + "' is missing");
    return fallback;
  }
  try {
    std::size_t used = 0;
    const double d = std::stod(*v, &used);
    if (used != v->size() || !std::isfinite(d)) throw std::invalid_argument(*v);
    return d;
  } catch (const std::exception&) {
    throw std::invalid_argument(path + ": metadata '" + key + "': not a number: '" + *v + "'");
  }
}

using effects::Pt;

std::vector<Pt> points_of(const std::vector<ProfileRun>& runs) {
  // Time counts from the earliest point: a Unix-epoch clock (~1.8e9 s) would make a drift column
  // nearly constant and cost the run-out's phase its digits.
  double origin_s = std::numeric_limits<double>::infinity();
  for (const auto& r : runs)
    for (double t : r.t_s) origin_s = std::min(origin_s, t);
  std::vector<Pt> pts;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const auto& r = runs[k];
    if (r.x_m.size() != r.z_m.size() || r.x_m.size() != r.t_s.size())
      throw std::invalid_argument(r.source + ": x, z and t differ in length");
    if (r.x_m.size() < 32)
      throw std::invalid_argument(r.source + ": too few points (" + std::to_string(r.x_m.size()) + ", need 32)");
    if (!(r.feed_mm_per_min > 0) || !(r.spindle_rpm > 0))
      throw std::invalid_argument(r.source + ": feed and spindle speed must be positive");
    for (std::size_t i = 0; i < r.x_m.size(); ++i) {
      if (!std::isfinite(r.x_m[i]) || !std::isfinite(r.z_m[i]) || !std::isfinite(r.t_s[i]))
        throw std::invalid_argument(r.source + ": point " + std::to_string(i + 1) + " is not finite");
      pts.push_back({k, r.x_m[i] * 1e3, r.t_s[i] - origin_s, r.z_m[i] * 1e6, r.feed_mm_per_min, r.spindle_rpm});
    }
  }
  return pts;
}

std::vector<RunInfo> infos(const std::vector<ProfileRun>& runs) {
  std::vector<RunInfo> out;
  for (std::size_t k = 0; k < runs.size(); ++k)
    out.push_back({"profile" + std::to_string(k + 1) + " (" + printf_number("%g", runs[k].feed_mm_per_min) + " mm/min)",
                   1, runs[k].feed_mm_per_min, "face", runs[k].source, 0.0});
  return out;
}

// `reading`: the reading the base predicts per point. `base`, `y_um`, `offset_um`: the base refitted, what
// it explains and the known curve added to its reading (null for a given prediction).
Problem assemble(const std::vector<ProfileRun>& runs, const std::vector<Pt>& g, const std::string& model,
                 const std::vector<double>& reading, bool measured_pitch = false, const Block* base = nullptr,
                 const Eigen::VectorXd* y_um = nullptr, const std::vector<double>* offset_um = nullptr) {
  Problem p;
  p.model = model;
  p.domain = "position_mm";
  p.runs = infos(runs);
  for (const auto& q : g) p.samples.push_back({q.run, q.y_um, q.x_mm, q.t_s});
  // Locations: a profile's time counts from its first point; the machine clock is the profiles' own.
  double origin_s = std::numeric_limits<double>::infinity();
  for (const auto& r : runs)
    for (double t : r.t_s) origin_s = std::min(origin_s, t);
  p.clock_origin_s = origin_s;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    p.runs[k].source = runs[k].source;
    p.runs[k].start_s =
        runs[k].t_s.empty() ? 0.0 : *std::min_element(runs[k].t_s.begin(), runs[k].t_s.end()) - origin_s;
  }
  const effects::ProfileTerms terms{g, runs, reading, measured_pitch, base, y_um, offset_um};
  p.candidates = effects::profile_candidates(terms);
  bool two_feeds = false;
  for (const auto& r : runs) two_feeds |= r.feed_mm_per_min != runs.front().feed_mm_per_min;
  if (!two_feeds)
    p.notes.push_back(
        "one feed rate only: a thermal drift at constant feed is a straight line in x, the signature of "
        "squareness; compare two feed rates to tell them apart");
  return p;
}

}  // namespace

ProfileRun read_profile_run(const std::string& path) { return profile_run(formats::read_profile_csv(path), path); }

ProfileRun profile_run(const formats::Profile& prof, const std::string& path) {
  ProfileRun r;
  r.source = path;
  r.feed_mm_per_min = meta_number(prof, path, "feed_mm_per_min", 0, true);
  r.spindle_rpm = meta_number(prof, path, "spindle_rpm", 0, true);
  if (!(r.feed_mm_per_min > 0)) throw std::invalid_argument(path + ": feed_mm_per_min must be positive");
  if (!(r.spindle_rpm > 0)) throw std::invalid_argument(path + ": spindle_rpm must be positive");
  const double t0 = meta_number(prof, path, "start_time_s", 0, false);
  if (prof.x_m.empty()) throw std::invalid_argument(path + ": no points");
  const double x0 = meta_number(prof, path, "cut_start_mm", prof.x_m.front() * 1e3, false) * 1e-3;
  for (std::size_t i = 0; i < prof.x_m.size(); ++i) {
    if (!std::isfinite(prof.z_m[i]))
      throw std::invalid_argument(path + ": point " + std::to_string(i + 1) + " is invalid (NaN)");
    r.x_m.push_back(prof.x_m[i]);
    r.z_m.push_back(prof.z_m[i]);
    r.t_s.push_back(t0 + std::abs(prof.x_m[i] - x0) / (r.feed_mm_per_min / 60000.0));
  }
  return r;
}

Problem profile_problem(const std::vector<ProfileRun>& runs, const std::string& model,
                        const flatness::AngleTraverse* straightness) {
  if (runs.empty()) throw std::invalid_argument("explain: no profiles");
  if (model != "flatness" && model != "straightness")
    throw std::invalid_argument("explain: unknown profile model '" + model + "'");
  if (straightness && model != "flatness")
    throw std::invalid_argument(
        "explain: a measured straightness traverse (" + straightness->source +
        ") belongs to the flatness model (Mu Eq. 16); the straightness model fits its own polynomial");
  auto g = points_of(runs);
  // Eq. 16's measured straightness y2: the traverse's Eq. 10 polynomial (as `guideway identify flatness`
  // evaluates it), a known curve subtracted from every profile; its slope is the pitch (Eq. 12).
  std::vector<double> y2_um(g.size(), 0.0);
  std::string straightness_note;
  if (straightness) {
    const flatness::AngleTraverse& tr = *straightness;
    if (tr.pitch_rad.size() < 2 || tr.x_m.empty())
      throw std::invalid_argument("explain: " + tr.source + ": too few traverse readings (need 2)");
    flatness::StraightnessOptions so;
    so.bootstrap = 0;  // only the polynomial is used
    const auto prof = flatness::straightness_from_angles(tr.x_m.front(), tr.step_m, tr.pitch_rad, so, "vertical");
    const double x0_mm = tr.x_m.front() * 1e3, x1_mm = prof.x_m.back() * 1e3, tol_mm = 1e-6;
    for (std::size_t i = 0; i < g.size(); ++i) {
      auto& p = g[i];
      if (p.x_mm < x0_mm - tol_mm || p.x_mm > x1_mm + tol_mm)
        throw std::invalid_argument("explain: " + runs[p.run].source + ": x = " + printf_number("%g", p.x_mm) +
                                    " mm leaves the straightness traverse of " + tr.source + " (" +
                                    printf_number("%g", x0_mm) + " to " + printf_number("%g", x1_mm) + " mm)");
      const double u = (p.x_mm - x0_mm) * 1e-3;
      y2_um[i] = prof.polynomial(u) * 1e6;
      p.pitch_rad = prof.polynomial.slope(u);
      p.y_um -= y2_um[i];
    }
    straightness_note = "base: Mu Eq. 16 with the measured straightness of " + tr.source +
                        " (Eq. 10 polynomial of order " + std::to_string(prof.polynomial.order) + ", " +
                        printf_number("%g", x0_mm) + " to " + printf_number("%g", x1_mm) +
                        " mm) subtracted from every profile";
  } else if (model == "flatness") {
    straightness_note =
        "measured straightness not supplied (--straightness): the base is Eq. 16's squareness only, so the "
        "X carriage's straightness stays in the residual (and abbe_offset, which needs the measured pitch, "
        "is not tried)";
  }
  Block base;
  const std::size_t nr = runs.size();
  for (std::size_t k = 0; k < nr; ++k) base.names.push_back("offset_profile" + std::to_string(k + 1) + "_um");
  if (model == "flatness") {
    base.names.push_back("squareness_urad");
  } else {
    for (const char* n : {"slope_urad", "quadratic_um_per_mm2", "cubic_um_per_mm3"}) base.names.push_back(n);
  }
  base.columns =
      Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(g.size()), static_cast<Eigen::Index>(base.names.size()));
  // Polynomials about the middle of the x range (conditioning).
  double lo = 1e300, hi = -1e300;
  for (const auto& p : g) {
    lo = std::min(lo, p.x_mm);
    hi = std::max(hi, p.x_mm);
  }
  const double mid = 0.5 * (lo + hi);
  for (std::size_t i = 0; i < g.size(); ++i) {
    const auto r = static_cast<Eigen::Index>(i);
    base.columns(r, static_cast<Eigen::Index>(g[i].run)) = 1.0;
    const double u = g[i].x_mm - mid;
    const auto c0 = static_cast<Eigen::Index>(nr);
    base.columns(r, c0) = u * 1e-3;  // 1 urad over 1 mm = 1e-3 um
    if (model == "straightness") {
      base.columns(r, c0 + 1) = u * u;
      base.columns(r, c0 + 2) = u * u * u;
    }
  }
  Eigen::VectorXd y(static_cast<Eigen::Index>(g.size()));
  for (std::size_t i = 0; i < g.size(); ++i) y[static_cast<Eigen::Index>(i)] = g[i].y_um;
  const LsqResult fit = solve_lsq(base.columns, y, Eigen::VectorXd(), base.names);
  if (!fit.ok) throw std::invalid_argument("explain: base fit failed: " + fit.message);
  // The reading the base predicts (the measured straightness included).
  std::vector<double> reading(g.size());
  for (std::size_t i = 0; i < g.size(); ++i)
    reading[i] = y[static_cast<Eigen::Index>(i)] - fit.residual[static_cast<Eigen::Index>(i)] + y2_um[i];
  Problem p = assemble(runs, g, model, reading, straightness != nullptr, &base, &y, &y2_um);
  if (!straightness_note.empty()) p.notes.insert(p.notes.begin(), straightness_note);
  p.base = std::move(base);
  return p;
}

Problem profile_compare_problem(const ProfileRun& simulated, const ProfileRun& measured) {
  if (simulated.x_m.size() != measured.x_m.size())
    throw std::invalid_argument("explain: " + simulated.source + " has " + std::to_string(simulated.x_m.size()) +
                                " points, " + measured.source + " has " + std::to_string(measured.x_m.size()));
  for (std::size_t i = 0; i < simulated.x_m.size(); ++i)
    if (std::abs(simulated.x_m[i] - measured.x_m[i]) > 1e-9)
      throw std::invalid_argument("explain: " + simulated.source + " and " + measured.source +
                                  " differ in x at point " + std::to_string(i + 1));
  ProfileRun diff = measured;
  for (std::size_t i = 0; i < diff.z_m.size(); ++i) diff.z_m[i] -= simulated.z_m[i];
  const std::vector<ProfileRun> runs{diff};
  const auto g = points_of(runs);
  std::vector<double> reading(simulated.z_m.size());
  for (std::size_t i = 0; i < reading.size(); ++i) reading[i] = simulated.z_m[i] * 1e6;
  Problem p = assemble(runs, g, "profile (simulated vs measured)", reading);
  p.notes.push_back("no base refit: the residual is " + measured.source + " - " + simulated.source);
  return p;
}

Report explain_profiles(const std::vector<ProfileRun>& runs, const std::string& model,
                        const flatness::AngleTraverse* straightness, const ExplainOptions& options) {
  return explain(profile_problem(runs, model, straightness), options);
}

Report explain_profile_difference(const ProfileRun& simulated, const ProfileRun& measured,
                                  const ExplainOptions& options) {
  return explain(profile_compare_problem(simulated, measured), options);
}

}  // namespace guideway::models::explain
