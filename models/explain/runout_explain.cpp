#include "models/explain/runout_explain.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "core/csv_table.hpp"
#include "core/number_format.hpp"
#include "models/common/least_squares.hpp"
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/runout_terms.hpp"
#include "models/flatness/error_motion.hpp"
#include "models/flatness/runout.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain {

namespace effects {

Variant line_variant(const RunoutTerms& t, double order, const results::Parameter& amp,
                     const results::Parameter& phase) {
  const std::size_t pairs = t.runs;
  const auto suffixed = [pairs](const std::string& name, std::size_t k) {
    return pairs > 1 ? results::run_suffixed(name, static_cast<int>(k + 1)) : name;
  };
  std::vector<std::string> names;
  for (std::size_t k = 0; k < pairs; ++k)
    for (const results::Parameter* p : {&results::runout_order_sin, &results::runout_order_cos})
      names.push_back(suffixed(results::name(*p), k));
  Variant v = make_variant(t.g, std::move(names), [order](const Rp& p, double* o) {
    o[2 * p.run] = std::sin(order * p.theta_rad);
    o[2 * p.run + 1] = std::cos(order * p.theta_rad);
  });
  v.fixed.push_back({results::name(results::runout_order), order, std::numeric_limits<double>::quiet_NaN()});
  v.searched = 1;
  v.report = [pairs, suffixed, amp_name = results::name(amp), phase_name = results::name(phase)](
                 const Eigen::VectorXd& x, const Eigen::MatrixXd& cov) {
    std::vector<ParamValue> out;
    for (std::size_t k = 0; k < pairs; ++k) {
      const auto j = static_cast<Eigen::Index>(2 * k);
      for (ParamValue& pv :
           amp_phase(suffixed(amp_name, k), suffixed(phase_name, k), x.segment(j, 2), cov.block(j, j, 2, 2)))
        out.push_back(std::move(pv));
    }
    return out;
  };
  return v;
}

}  // namespace effects

namespace {

constexpr double two_pi = 2.0 * std::numbers::pi;

}  // namespace

RunoutRecord runout_record(const flatness::RunoutRevolution& rev, double rpm) {
  if (!(rpm > 0) || !std::isfinite(rpm))
    throw std::invalid_argument(rev.source + ": the spindle speed (rpm) must be positive, not " + shortest(rpm));
  RunoutRecord r;
  r.source = rev.source;
  r.rpm = rpm;
  r.angle_rad = rev.angle_rad;
  r.runout_m = rev.runout_m;
  return r;
}

RunoutRecord read_runout_record(const std::string& path) {
  const std::string text = read_text_file(path);
  const auto rpm = parse_csv_table(text, path).optional_metadata_number("rpm");
  if (!rpm)
    throw std::invalid_argument(path + ": metadata 'rpm' is missing (the spindle speed gives each reading its time)");
  return runout_record(flatness::parse_runout_revolution(text, path), *rpm);
}

Problem runout_problem(const std::vector<RunoutRecord>& records) {
  if (records.empty()) throw std::invalid_argument("explain: no run-out records");
  Problem p;
  p.model = "runout";
  p.domain = "angle_deg";
  std::vector<effects::Rp> g;
  double revolutions = 1e300, per_rev = 1e300;
  for (std::size_t k = 0; k < records.size(); ++k) {
    const RunoutRecord& r = records[k];
    if (r.angle_rad.size() != r.runout_m.size())
      throw std::invalid_argument(r.source + ": angles and readings differ in number");
    const std::size_t whole = flatness::whole_revolutions(r.angle_rad);
    if (whole < 2)
      throw std::invalid_argument(
          r.source + ": " + std::to_string(whole) +
          " whole revolutions; EXPLAIN of a run-out needs at least 2 (what repeats and what does not)");
    for (std::size_t i = 1; i < r.angle_rad.size(); ++i)
      if (!(r.angle_rad[i] > r.angle_rad[i - 1]))
        throw std::invalid_argument(r.source + ": the angle does not increase at reading " + std::to_string(i + 1));
    const double a0 = r.angle_rad.front(), omega = r.rpm / 60.0 * two_pi;
    const double span = r.angle_rad.back() - a0;
    revolutions = std::min(revolutions, span / two_pi);
    per_rev = std::min(per_rev, static_cast<double>(r.angle_rad.size()) / (span / two_pi));
    for (std::size_t i = 0; i < r.angle_rad.size(); ++i) {
      if (!std::isfinite(r.runout_m[i]))
        throw std::invalid_argument(r.source + ": reading " + std::to_string(i + 1) + " is not finite");
      const double theta = r.angle_rad[i] - a0;
      g.push_back({k, theta, theta / omega, omega});
      p.samples.push_back({k, r.runout_m[i] * 1e6, std::fmod(theta, two_pi) * 180.0 / std::numbers::pi, theta / omega});
    }
    p.runs.push_back(
        {r.source + " (" + printf_number("%g", r.rpm) + " rpm, " + std::to_string(whole) + " rev)", 1, 0.0, "runout"});
  }
  // Base: per record an offset and the once-per-revolution term (the face's tilt, the set-up's centring).
  const std::size_t nr = records.size();
  p.base.names.clear();
  for (std::size_t k = 0; k < nr; ++k) {
    const int run = nr > 1 ? static_cast<int>(k + 1) : 0;
    for (const char* n : {"offset_um", "once_per_rev_cos_um", "once_per_rev_sin_um"})
      p.base.names.push_back(run ? results::run_suffixed(n, run) : std::string(n));
  }
  p.base.columns = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(g.size()), static_cast<Eigen::Index>(3 * nr));
  Eigen::VectorXd y(static_cast<Eigen::Index>(g.size()));
  for (std::size_t i = 0; i < g.size(); ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    const auto c = static_cast<Eigen::Index>(3 * g[i].run);
    p.base.columns(row, c) = 1.0;
    p.base.columns(row, c + 1) = std::cos(g[i].theta_rad);
    p.base.columns(row, c + 2) = std::sin(g[i].theta_rad);
    y[row] = p.samples[i].y_um;
  }
  const LsqResult fit = solve_lsq(p.base.columns, y, Eigen::VectorXd(), p.base.names);
  if (!fit.ok) throw std::invalid_argument("explain: base fit failed: " + fit.message);
  const double highest = std::clamp(std::floor(per_rev / 4.0), 2.0, 50.0);
  const effects::RunoutTerms terms{g, nr, revolutions, highest, p.base, y};
  p.candidates = effects::runout_candidates(terms);
  // Records share no clock: a term of time (growth, a line's phase) has its own part per record.
  p.terms_per_run = nr > 1;
  p.notes.push_back(
      "angles from time at the nominal rpm (the micrometer reads no spindle angle); orders searched up to " +
      printf_number("%g", highest) + " per revolution, resolved to 1/" + printf_number("%.3g", revolutions) +
      " of an order");
  return p;
}

Report explain_runout(const std::vector<RunoutRecord>& records, const ExplainOptions& options) {
  return explain(runout_problem(records), options);
}

}  // namespace guideway::models::explain
