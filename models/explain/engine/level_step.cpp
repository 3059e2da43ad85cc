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

// What a step is sought beside, as an orthonormal basis q, and the residual r beyond it.
struct Beyond {
  Eigen::MatrixXd q;
  Eigen::VectorXd r;
};

// The base and every run's own level: a step within the run, not one run's level against another's (that alone is a
// ccw/cw effect's, a lateral play's).
Beyond beyond_levels(const Problem& p, const Eigen::VectorXd& y) {
  const auto n = y.size();
  const auto ranges = run_ranges(p);
  const Eigen::Index p0 = p.base.columns.cols();
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n, p0 + static_cast<Eigen::Index>(ranges.size()));
  if (p0 > 0) x.leftCols(p0) = p.base.columns;
  for (std::size_t k = 0; k < ranges.size(); ++k)
    x.col(p0 + static_cast<Eigen::Index>(k))
        .segment(static_cast<Eigen::Index>(ranges[k].first),
                 static_cast<Eigen::Index>(ranges[k].second - ranges[k].first))
        .setOnes();
  Beyond out;
  out.q = x.cols() > 0 ? span_basis(std::move(x)) : Eigen::MatrixXd(n, 0);
  out.r = out.q.cols() > 0 ? Eigen::VectorXd(y - out.q * (out.q.transpose() * y)) : y;
  return out;
}

// Per sample i of a run [a, b) searched, the sum of squares a step over [i, b) takes from the residual `beyond` leaves,
// and the step's size.
struct RunSteps {
  std::size_t run = 0, first = 0;  // the run, and the sample of stat[0]
  std::vector<double> stat, size_um;
};

RunSteps steps_in_run(const Beyond& beyond, std::size_t run, std::size_t a, std::size_t b) {
  RunSteps out;
  out.run = run;
  const std::size_t len = b - a, margin = std::max<std::size_t>(1, len / 32);
  if (len < min_run_samples || len <= 2 * margin) return out;
  const Eigen::MatrixXd& q = beyond.q;
  const Eigen::VectorXd& r = beyond.r;
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

// The strongest step beside `beyond` (level_step), with the residual's sum of squares and the parameters of the model
// with it.
struct Strongest {
  LevelStep step;
  double rss = 0, parameters = 0;
};

std::optional<Strongest> strongest_step(const Problem& problem, const Beyond& beyond, double sigma_um, double alpha) {
  const auto ranges = run_ranges(problem);
  std::vector<RunSteps> runs;
  std::size_t searched = 0;
  for (std::size_t k = 0; k < ranges.size(); ++k) {
    runs.push_back(steps_in_run(beyond, k, ranges[k].first, ranges[k].second));
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
  return Strongest{LevelStep{location_of(problem, best->first + lo - 1, best->first + hi + 1, best->size_um[at]),
                             best->run, best->first + at},
                   beyond.r.squaredNorm() - best->stat[at], static_cast<double>(beyond.q.cols()) + 1};
}

}  // namespace

std::optional<LevelStep> level_step(const Problem& problem, double sigma_um, double alpha) {
  if (!(sigma_um > 0) || problem.station_means_absorbed) return std::nullopt;
  const Eigen::VectorXd y = observations(problem);
  std::optional<Strongest> s = strongest_step(problem, beyond_levels(problem, y), sigma_um, alpha);
  if (!s) return std::nullopt;
  return std::move(s->step);
}

std::optional<WinningStep> winning_step(const Problem& problem, double sigma_um, double alpha,
                                        const std::vector<TermColumns>& terms, double bic) {
  const std::size_t k = terms.size();
  if (!(sigma_um > 0) || problem.station_means_absorbed || k > step_check_max_terms) return std::nullopt;
  const Eigen::VectorXd y = observations(problem);
  const Eigen::Index n = y.size();
  std::vector<Eigen::MatrixXd> scratch;
  const std::vector<const Eigen::MatrixXd*> columns = columns_of_terms(problem, terms, n, scratch);
  if (columns.size() != k) return std::nullopt;
  // Beside the base and the levels once; each term's columns scaled to unit norm and taken beyond them once, a
  // subset's basis beyond them made of its own (the threshold a joint pivoted QR would apply: unit_span_basis).
  const Beyond levels = beyond_levels(problem, y);
  std::vector<Eigen::Index> first_column;
  Eigen::Index width = 0;
  for (const Eigen::MatrixXd* c : columns) {
    first_column.push_back(width);
    width += c->cols();
  }
  Eigen::MatrixXd all(n, width);
  for (std::size_t j = 0; j < k; ++j) all.middleCols(first_column[j], columns[j]->cols()) = *columns[j];
  scale_columns(all);
  if (levels.q.cols() > 0) all -= levels.q * (levels.q.transpose() * all);
  // A subset's basis: the levels' and its own; made one subset at a time (an n-row copy each), the best made again.
  const auto beside_of = [&](std::size_t subset, std::size_t& searched) {
    std::vector<Eigen::Index> picked;
    searched = 0;
    for (std::size_t j = 0; j < k; ++j)
      if (subset >> j & 1U) {
        for (Eigen::Index c = 0; c < columns[j]->cols(); ++c) picked.push_back(first_column[j] + c);
        searched += terms[j].searched;
      }
    Beyond beside;
    const Eigen::MatrixXd qs = unit_span_basis(all(Eigen::all, picked));
    beside.q.resize(n, levels.q.cols() + qs.cols());
    beside.q.leftCols(levels.q.cols()) = levels.q;
    beside.q.rightCols(qs.cols()) = qs;
    beside.r = levels.r;
    beside.r -= qs * (qs.transpose() * levels.r);
    return beside;
  };
  const double ln_n = std::log(static_cast<double>(n));
  double best = bic - ln_n;
  std::optional<Strongest> found;
  std::size_t found_subset = 0;
  for (std::size_t subset = 0; subset < (std::size_t{1} << k); ++subset) {
    std::size_t searched = 0;
    std::optional<Strongest> s;
    if (subset == 0) {
      s = strongest_step(problem, levels, sigma_um, alpha);
    } else {
      const Beyond beside = beside_of(subset, searched);
      s = strongest_step(problem, beside, sigma_um, alpha);
    }
    if (!s) continue;
    const double b = bic_of(s->rss, s->parameters + static_cast<double>(searched), static_cast<double>(n));
    if (b < best) {
      best = b;
      found = std::move(s);
      found_subset = subset;
    }
  }
  if (!found) return std::nullopt;
  std::size_t searched = 0;
  const Beyond found_beside = found_subset == 0 ? Beyond{} : beside_of(found_subset, searched);
  const Beyond& beside = found_subset == 0 ? levels : found_beside;
  // The residual of that model: the step's column beyond the basis, at its size, taken from the residual beyond it.
  const LevelStep& step = found->step;
  Eigen::VectorXd column = Eigen::VectorXd::Zero(n);
  const std::size_t end = run_ranges(problem)[step.run].second;
  column.segment(static_cast<Eigen::Index>(step.at), static_cast<Eigen::Index>(end - step.at)).setOnes();
  const Eigen::MatrixXd& q = beside.q;
  if (q.cols() > 0) column -= q * (q.transpose() * column);
  return WinningStep{step, beside.r - step.place.peak_um * column};
}

bool step_could_win(const Problem& problem, const std::vector<OffsetAfter>& offsets, const Pass& first) {
  const std::size_t k = first.terms.size();
  if (k > step_check_max_terms) return true;
  const Eigen::VectorXd y = observations(problem);
  const Eigen::Index n = y.size();
  std::vector<Eigen::MatrixXd> scratch;
  const std::vector<const Eigen::MatrixXd*> columns = columns_of_terms(problem, first.terms, n, scratch);
  if (columns.size() != k) return true;
  const Eigen::Index p0 = problem.base.columns.cols(), m = static_cast<Eigen::Index>(offsets.size());
  Eigen::Index w = p0 + m;
  std::vector<Eigen::Index> first_column;  // of each term, in [base offsets terms y]
  for (const Eigen::MatrixXd* c : columns) {
    first_column.push_back(w);
    w += c->cols();
  }
  // One pass over the samples for every subset: the factor of [base offsets terms y], its chunks made as they are
  // read (the offsets are indicator columns; no n-row copy of the design is made).
  const Eigen::MatrixXd r = tall_r_rows(n, w + 1, [&](Eigen::Index from, Eigen::Ref<Eigen::MatrixXd> part) {
    const Eigen::Index rows = part.rows();
    if (p0 > 0) part.leftCols(p0) = problem.base.columns.middleRows(from, rows);
    for (Eigen::Index c = 0; c < m; ++c)
      for (Eigen::Index i = 0; i < rows; ++i)
        part(i, p0 + c) =
            stands_off(problem, offsets[static_cast<std::size_t>(c)], static_cast<std::size_t>(from + i)) ? 1.0 : 0.0;
    for (std::size_t j = 0; j < k; ++j)
      part.middleCols(first_column[j], columns[j]->cols()) = columns[j]->middleRows(from, rows);
    part.col(w) = y.segment(from, rows);
  });
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t subset = 0; subset < (std::size_t{1} << k); ++subset) {
    std::vector<Eigen::Index> chosen;
    for (Eigen::Index c = 0; c < p0 + m; ++c) chosen.push_back(c);
    std::size_t searched = 0;
    for (std::size_t j = 0; j < k; ++j)
      if (subset >> j & 1U) {
        for (Eigen::Index c = 0; c < columns[j]->cols(); ++c) chosen.push_back(first_column[j] + c);
        searched += first.terms[j].searched;
      }
    const ColumnsFit fit = fit_of_columns(r, chosen);
    best = std::min(best, bic_of(fit.rss, static_cast<double>(fit.rank) + static_cast<double>(searched),
                                 static_cast<double>(n)));
  }
  return best + std::log(static_cast<double>(n)) < first.report.final_fit.bic;
}

}  // namespace guideway::models::explain::engine
