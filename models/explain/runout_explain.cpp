// EXPLAIN for spindle run-out records (runout_explain.hpp): per record an offset and the once-per-revolution term.
#include "models/explain/runout_explain.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <stdexcept>

#include <Eigen/QR>

#include "core/csv_table.hpp"
#include "core/number_format.hpp"
#include "results/session_kinds.hpp"
#include "models/common/least_squares.hpp"
#include "models/explain/effects/effect.hpp"
#include "models/explain/effects/runout_terms.hpp"
#include "models/flatness/error_motion.hpp"
#include "models/flatness/runout.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain {

namespace effects {

Variant line_variant(const RunoutTerms& t, double order, const results::Parameter& amp, const results::Parameter& phase,
                     const std::function<double(const Rp&)>& weight) {
  const std::size_t pairs = t.runs;
  const auto suffixed = [pairs](const std::string& name, std::size_t k) {
    return pairs > 1 ? results::run_suffixed(name, static_cast<int>(k + 1)) : name;
  };
  std::vector<std::string> names;
  for (std::size_t k = 0; k < pairs; ++k)
    for (const results::Parameter* p : {&results::runout_order_sin, &results::runout_order_cos})
      names.push_back(suffixed(results::name(*p), k));
  Variant v = make_variant(t.g, std::move(names), [order, weight](const Rp& p, double* o) {
    const double w = weight ? weight(p) : 1.0;
    o[2 * p.run] = w * std::sin(order * p.theta_rad);
    o[2 * p.run + 1] = w * std::cos(order * p.theta_rad);
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

Variant reversal_line_variant(const RunoutTerms& t, int order, bool turning, const results::Parameter& amp,
                              const results::Parameter& phase) {
  const double k = order;
  Variant v = make_variant(t.g, {results::name(results::runout_order_sin), results::name(results::runout_order_cos)},
                           [k, turning](const Rp& p, double* o) {
                             const double a = p.spindle_rad - (turning ? p.artifact_rad : 0.0);
                             o[0] = std::sin(k * a);
                             o[1] = std::cos(k * a);
                           });
  v.fixed.push_back({results::name(results::runout_order), k, std::numeric_limits<double>::quiet_NaN()});
  v.report = [amp_name = results::name(amp), phase_name = results::name(phase)](const Eigen::VectorXd& x,
                                                                                const Eigen::MatrixXd& cov) {
    return amp_phase(amp_name, phase_name, x, cov);
  };
  return v;
}

bool reversal_separates(const RunoutTerms& t, int order) {
  if (!t.reversal) return false;
  // The records' turns against the first record's (every row of a record carries its turn).
  const double first = t.g.front().artifact_rad;
  for (const Rp& p : t.g)
    if (std::abs(1.0 - std::polar(1.0, order * (p.artifact_rad - first))) >= 1.0) return true;
  return false;
}

bool OrderGrid::near_whole(double order) const { return std::abs(order - std::round(order)) < resolution; }

std::size_t OrderGrid::searched() const {
  std::size_t n = 0;
  for (std::size_t k = 0; k < size; ++k) n += near_whole(at(k)) ? 0 : 1;
  return n;
}

OrderGrid non_integer_orders(const RunoutTerms& t) {
  OrderGrid grid;
  grid.resolution = 1.0 / t.revolutions;
  grid.lo = 4.0 * grid.resolution;
  grid.step = grid.resolution / 4.0;
  if (t.highest_order > grid.lo)
    grid.size = static_cast<std::size_t>(std::floor((t.highest_order - grid.lo) / grid.step)) + 1;
  return grid;
}

double strongest_order(const std::vector<Rp>& g, std::size_t runs, const OrderGrid& grid, const Eigen::VectorXd& r,
                       const std::vector<bool>& use, const std::vector<double>& weight) {
  std::vector<std::complex<double>> acc(grid.size * runs);
  for (std::size_t i = 0; i < g.size(); ++i) {
    if (!use[i]) continue;
    const double th = g[i].theta_rad;
    const double w = weight.empty() ? 1.0 : weight[i];
    std::complex<double> z = std::polar(w * r[static_cast<Eigen::Index>(i)], -grid.lo * th);
    const std::complex<double> step = std::polar(1.0, -grid.step * th);
    std::complex<double>* a = acc.data() + g[i].run * grid.size;
    for (std::size_t k = 0; k < grid.size; ++k, z *= step) a[k] += z;
  }
  std::vector<double> power(grid.size, 0.0);
  for (std::size_t run = 0; run < runs; ++run)
    for (std::size_t k = 0; k < grid.size; ++k) power[k] += std::norm(acc[run * grid.size + k]);
  std::size_t best = grid.size;
  for (std::size_t k = 0; k < grid.size; ++k)
    if (!grid.near_whole(grid.at(k)) && (best == grid.size || power[k] > power[best])) best = k;
  if (best == grid.size) return std::numeric_limits<double>::quiet_NaN();
  double order = grid.at(best);
  if (best > 0 && best + 1 < grid.size) {
    const double a = power[best - 1], b = power[best], d = power[best + 1];
    const double den = a - 2 * b + d;
    if (den < 0) order += grid.step * std::clamp(0.5 * (a - d) / den, -0.5, 0.5);
  }
  return order;
}

Eigen::VectorXd base_coefficients(const Block& base, const Eigen::VectorXd& y, const std::vector<bool>& use) {
  const auto rows = rows_in_use(use);
  if (rows.size() <= static_cast<std::size_t>(base.columns.cols())) return {};
  const Eigen::MatrixXd j = base.columns(rows, Eigen::all);
  return j.colPivHouseholderQr().solve(y(rows));
}

double once_per_rev_slope(const Eigen::VectorXd& coef, const Rp& p) {
  const auto c = static_cast<Eigen::Index>(3 * p.run);
  return -coef[c + 1] * std::sin(p.theta_rad) + coef[c + 2] * std::cos(p.theta_rad);
}

}  // namespace effects

namespace {

constexpr double two_pi = 2.0 * std::numbers::pi;

// Whether the records are a reversal EXPLAIN can use: "" when they are, else why not (for the notes);
// nothing is said when no record states a turn.
std::string reversal_refusal(const std::vector<RunoutRecord>& records) {
  bool stated = false, turned = false;
  const double first = records.front().artifact_turned_rad.value_or(0.0);
  for (const RunoutRecord& r : records) {
    stated = stated || r.artifact_turned_rad.has_value();
    turned = turned || std::abs(std::remainder(r.artifact_turned_rad.value_or(0.0) - first, two_pi)) > 1e-9;
  }
  if (!stated) return "";
  if (records.size() < 2) return "one record: a reversal compares two, the artifact turned between them";
  if (!turned) return "every record states the same turn of the artifact: nothing turned between them";
  for (const RunoutRecord& r : records)
    if (!r.angle_from_spindle_zero)
      return r.source +
             "'s angles count from its first reading (angle_zero = first_reading; the micrometer reads no spindle "
             "angle): a reversal needs every record's angles from the spindle's zero (an index or encoder)";
  return "";
}

// The note of a reversal: the turns, the orders separated and those a turn leaves together.
std::string reversal_note(const std::vector<RunoutRecord>& records, const effects::RunoutTerms& terms) {
  std::string turns, separated, together;
  for (const RunoutRecord& r : records)
    turns += (turns.empty() ? "" : ", ") +
             printf_number("%g", r.artifact_turned_rad.value_or(0.0) * 180.0 / std::numbers::pi);
  for (int k = 2; k <= static_cast<int>(terms.highest_order); ++k) {
    std::string& list = effects::reversal_separates(terms, k) ? separated : together;
    list += (list.empty() ? "" : ", ") + std::to_string(k);
  }
  std::string note = "reversal (Donaldson): the artifact turned " + turns +
                     " deg in the records, angles from the spindle's zero: a harmonic is the spindle's error motion "
                     "(synchronous_harmonic, at the spindle's angle) or the artifact's form (artifact_form, turning "
                     "with it)";
  note += separated.empty() ? "; no order separated" : "; orders separated: " + separated;
  if (!together.empty())
    note += "; orders " + together + " stay together (the turn brings their form back within 60 deg of itself)";
  return note;
}

}  // namespace

RunoutRecord runout_record(const flatness::RunoutRevolution& rev, double rpm) {
  if (!(rpm > 0) || !std::isfinite(rpm))
    throw std::invalid_argument(rev.source + ": the spindle speed (rpm) must be positive, not " + shortest(rpm));
  RunoutRecord r;
  r.source = rev.source;
  r.rpm = rpm;
  r.angle_rad = rev.angle_rad;
  r.runout_m = rev.runout_m;
  r.artifact_turned_rad = rev.artifact_turned_rad;
  r.angle_from_spindle_zero = rev.angle_from_spindle_zero;
  return r;
}

RunoutRecord parse_runout_record(const std::string& text, const std::string& source) {
  const auto rpm = parse_csv_table(text, source)
                       .optional_metadata_in("rpm", results::runout_rpm.min, results::runout_rpm.max,
                                             "1/min, a spindle's speed (the runout session's range)");
  if (!rpm)
    throw std::invalid_argument(source + ": metadata 'rpm' is missing (the spindle speed gives each reading its time)");
  return runout_record(flatness::parse_runout_revolution(text, source), *rpm);
}

RunoutRecord read_runout_record(const std::string& path) { return parse_runout_record(read_text_file(path), path); }

Problem runout_problem(const std::vector<RunoutRecord>& records) {
  if (records.empty()) throw std::invalid_argument("explain: no run-out records");
  Problem p;
  p.model = "runout";
  p.domain = "angle_deg";
  std::vector<effects::Rp> g;
  double revolutions = 1e300, per_rev = 1e300;
  const std::string refusal = reversal_refusal(records);
  const bool reversal = refusal.empty() && std::any_of(records.begin(), records.end(), [](const RunoutRecord& r) {
                          return r.artifact_turned_rad.has_value();
                        });
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
      g.push_back({k, theta, theta / omega, omega, r.angle_rad[i], r.artifact_turned_rad.value_or(0.0)});
      p.samples.push_back({k, r.runout_m[i] * 1e6, std::fmod(theta, two_pi) * 180.0 / std::numbers::pi, theta / omega});
    }
    p.runs.push_back(
        {r.source + " (" + printf_number("%g", r.rpm) + " rpm, " + std::to_string(whole) + " rev)", 1, 0.0, "runout",
         "", 0.0});  // no source beside a label that names the file
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
  const effects::RunoutTerms terms{g, nr, revolutions, highest, p.base, y, reversal};
  p.candidates = effects::runout_candidates(terms);
  if (reversal) p.notes.push_back(reversal_note(records, terms));
  if (!refusal.empty())
    p.notes.push_back("no reversal: " + refusal +
                      "; the harmonics stay the spindle's error motion and the artifact's "
                      "form together");
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
