// A step in one run's level (level_step.hpp).
#include "models/explain/engine/level_step.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "models/explain/engine/explain_pass.hpp"
#include "models/explain/engine/model_fit.hpp"
#include "models/explain/engine/subspace.hpp"
#include "models/explain/locate.hpp"
#include "models/explain/stats.hpp"

namespace guideway::models::explain::engine {

namespace {

// The chi-square(1) quantile whose upper tail is alpha (bisection: chi2_sf falls with x).
double chi2_1_quantile(double alpha) {
  double lo = 0, hi = 200;
  for (int k = 0; k < 100; ++k) {
    const double mid = (lo + hi) / 2;
    (chi2_sf(mid, 1) > alpha ? lo : hi) = mid;
  }
  return (lo + hi) / 2;
}

// Per sample i of a run [a, b) searched, the sum of squares a step over [i, b) takes from the residual beyond the
// base and the later runs' level, and the step's size.
struct RunSteps {
  std::size_t run = 0, first = 0;  // the run, and the sample of stat[0]
  std::vector<double> stat, size_um;
};

RunSteps steps_in_run(const Problem& p, const Eigen::VectorXd& y, std::size_t run, std::size_t a, std::size_t b) {
  const auto n = y.size();
  RunSteps out;
  out.run = run;
  const std::size_t len = b - a, margin = std::max<std::size_t>(1, len / 32);
  if (len < min_run_samples || len <= 2 * margin) return out;
  // The base and every run's own level: a step within the run, not one run's level against another's (that alone is
  // a ccw/cw effect's, a lateral play's).
  const auto ranges = run_ranges(p);
  const Eigen::Index p0 = p.base.columns.cols();
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n, p0 + static_cast<Eigen::Index>(ranges.size()));
  if (p0 > 0) x.leftCols(p0) = p.base.columns;
  for (std::size_t k = 0; k < ranges.size(); ++k)
    x.col(p0 + static_cast<Eigen::Index>(k))
        .segment(static_cast<Eigen::Index>(ranges[k].first),
                 static_cast<Eigen::Index>(ranges[k].second - ranges[k].first))
        .setOnes();
  const Eigen::MatrixXd q = x.cols() > 0 ? span_basis(x) : Eigen::MatrixXd(n, 0);
  const Eigen::VectorXd r = q.cols() > 0 ? Eigen::VectorXd(y - q * (q.transpose() * y)) : y;
  // Suffix sums from the run's end: the step's column s = 1 on [i, b); beyond q it is s - q q's, whose norm^2 is
  // (b - i) - |q's|^2, and its product with r (already beyond q) is the sum of r over [i, b).
  out.first = a + margin;
  out.stat.assign(b - margin - out.first, 0.0);
  out.size_um.assign(out.stat.size(), 0.0);
  double sr = 0;
  Eigen::RowVectorXd sq = Eigen::RowVectorXd::Zero(q.cols());
  for (std::size_t i = b; i-- > out.first;) {
    sr += r[static_cast<Eigen::Index>(i)];
    if (q.cols() > 0) sq += q.row(static_cast<Eigen::Index>(i));
    if (i >= b - margin) continue;
    const double count = static_cast<double>(b - i), den = count - sq.squaredNorm();
    if (!(den > 1e-9 * count)) continue;
    out.stat[i - out.first] = sr * sr / den;
    out.size_um[i - out.first] = sr / den;
  }
  return out;
}

}  // namespace

std::optional<LevelStep> level_step(const Problem& problem, double sigma_um, double alpha) {
  if (!(sigma_um > 0) || problem.station_means_absorbed) return std::nullopt;
  const Eigen::VectorXd y = observations(problem);
  const auto ranges = run_ranges(problem);
  std::vector<RunSteps> runs;
  std::size_t searched = 0;
  for (std::size_t k = 0; k < ranges.size(); ++k) {
    runs.push_back(steps_in_run(problem, y, k, ranges[k].first, ranges[k].second));
    searched += runs.back().stat.size();
  }
  const RunSteps* best = nullptr;
  std::size_t at = 0;
  for (const RunSteps& rs : runs)
    for (std::size_t j = 0; j < rs.stat.size(); ++j)
      if (!best || rs.stat[j] > best->stat[at]) {
        best = &rs;
        at = j;
      }
  if (!best) return std::nullopt;
  const double top = best->stat[at] / (sigma_um * sigma_um);
  if (!(static_cast<double>(searched) * chi2_sf(top, 1) < alpha)) return std::nullopt;
  // Where the step may be: every sample whose step fits within the quantile of the best.
  const double within = chi2_1_quantile(alpha) * sigma_um * sigma_um;
  std::size_t lo = at, hi = at;
  for (std::size_t j = 0; j < best->stat.size(); ++j)
    if (best->stat[at] - best->stat[j] <= within) {
      lo = std::min(lo, j);
      hi = std::max(hi, j);
    }
  // From the last sample before the earliest step to the first after the latest.
  return LevelStep{location_of(problem, best->first + lo - 1, best->first + hi + 1, best->size_um[at]),
                   best->run, best->first + at};
}

bool step_could_win(const Problem& problem, const Eigen::MatrixXd& base_with_step, const Pass& first) {
  const std::size_t k = first.terms.size();
  if (k > step_check_max_terms) return true;
  const Eigen::VectorXd y = observations(problem);
  const Eigen::Index n = y.size();
  if (base_with_step.rows() != n) return true;
  std::vector<Eigen::MatrixXd> scratch(k);
  std::vector<const Eigen::MatrixXd*> columns;
  for (std::size_t j = 0; j < k; ++j) {
    const TermColumns& t = first.terms[j];
    columns.push_back(t.generated ? &t.all_samples
                                  : &columns_of(problem.candidates[t.cand].variants[t.index], n, scratch[j]));
    if (columns.back()->rows() != n) return true;
  }
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t subset = 0; subset < (std::size_t{1} << k); ++subset) {
    Eigen::Index width = base_with_step.cols();
    std::size_t searched = 0;
    for (std::size_t j = 0; j < k; ++j)
      if (subset >> j & 1U) {
        width += columns[j]->cols();
        searched += first.terms[j].searched;
      }
    Eigen::MatrixXd x(n, width);
    x.leftCols(base_with_step.cols()) = base_with_step;
    Eigen::Index at = base_with_step.cols();
    for (std::size_t j = 0; j < k; ++j)
      if (subset >> j & 1U) {
        x.middleCols(at, columns[j]->cols()) = *columns[j];
        at += columns[j]->cols();
      }
    const Eigen::MatrixXd q = span_basis(std::move(x));
    const double rss = q.cols() > 0 ? (y - q * (q.transpose() * y)).squaredNorm() : y.squaredNorm();
    best = std::min(best,
                    bic_of(rss, static_cast<double>(q.cols()) + static_cast<double>(searched), static_cast<double>(n)));
  }
  return best + std::log(static_cast<double>(n)) < first.report.final_fit.bic;
}

}  // namespace guideway::models::explain::engine
