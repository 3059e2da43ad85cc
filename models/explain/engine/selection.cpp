// The models EXPLAIN's selection compares (selection.hpp).
#include "models/explain/engine/selection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

#include <Eigen/SVD>

#include "models/explain/engine/subspace.hpp"

namespace guideway::models::explain::engine {

namespace {

// How much two blocks of columns share: the largest canonical correlation of their spans (the cosine
// of the smallest angle between them), 0 when one has no columns.
double overlap(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (a.cols() == 0 || b.cols() == 0) return 0.0;
  const Eigen::MatrixXd qa = span_basis(a), qb = span_basis(b);
  if (qa.cols() == 0 || qb.cols() == 0) return 0.0;
  const Eigen::MatrixXd c = qa.transpose() * qb;
  return Eigen::JacobiSVD<Eigen::MatrixXd>(c).singularValues()[0];
}

}  // namespace

Selection::Selection(const Problem& problem, const ExplainOptions& options, const Eigen::VectorXd& y,
                     const HeldOutScheme& scheme)
    : p_(problem),
      o_(options),
      y_(y),
      n_(static_cast<std::size_t>(y.size())),
      base_(problem.base.columns, scheme.fold_of, static_cast<std::size_t>(scheme.folds), absorbed_rank(problem)),
      fits_(problem, options, y, base_, fold_rows(scheme.fold_of, scheme.folds), choose_buffer_,
            cache_budget_bytes(options) / 2),
      models_(cache_budget_bytes(options) / 4),
      heldouts_(cache_budget_bytes(options) / 4) {}

LsqResult Selection::fit(const std::vector<Term>& terms) const {
  const Eigen::MatrixXd rest = term_columns(terms);
  ColumnBlocks design;
  if (p_.base.columns.cols() > 0) design.emplace_back(p_.base.columns);
  if (rest.cols() > 0) design.emplace_back(rest);
  if (design.empty()) {  // no column (a base fitted out of the data, no term): nothing fitted, the data left
    LsqResult data_left;
    data_left.ok = true;
    data_left.n = n_;
    data_left.residual = y_;
    data_left.rms = std::sqrt(y_.squaredNorm() / static_cast<double>(n_));
    data_left.s2 = y_.squaredNorm() / static_cast<double>(n_);
    data_left.condition_number = 1.0;
    return data_left;
  }
  LsqResult fit = solve_lsq(design, y_, Eigen::VectorXd(), names(terms));
  // The stations' terms fitted out of the data (Problem::station_means_absorbed) took their degrees of freedom too.
  if (const auto absorbed = static_cast<double>(base_.absorbed()); fit.ok && absorbed > 0) {
    const double dof = static_cast<double>(fit.n) - static_cast<double>(fit.rank);
    const double widen = dof > absorbed ? dof / (dof - absorbed) : std::numeric_limits<double>::infinity();
    fit.s2 *= widen;
    fit.covariance *= widen;
    fit.u *= std::sqrt(widen);
  }
  return fit;
}

Eigen::MatrixXd Selection::term_columns(const std::vector<Term>& terms, std::size_t skip) const {
  Eigen::Index cols = 0;
  for (std::size_t k = 0; k < terms.size(); ++k)
    if (k != skip) cols += width(variant_of(p_, terms[k]));
  Eigen::MatrixXd j(static_cast<Eigen::Index>(n_), cols);
  Eigen::Index at = 0;
  for (std::size_t k = 0; k < terms.size(); ++k) {
    if (k == skip) continue;
    const Variant& v = variant_of(p_, terms[k]);
    write_columns(v, j.middleCols(at, width(v)));
    at += width(v);
  }
  return j;
}

std::vector<std::string> Selection::names(const std::vector<Term>& terms) const {
  std::vector<std::string> out = p_.base.names;
  for (const auto& t : terms) {
    const auto& v = variant_of(p_, t).block.names;
    out.insert(out.end(), v.begin(), v.end());
  }
  return out;
}

Model Selection::model(const std::vector<Term>& terms, std::size_t skip) const {
  const auto key = VariantSetCache<Model>::key_of(p_, terms, skip);
  if (const Model* cached = models_.find(key)) return *cached;
  std::size_t searched = 0;
  for (std::size_t k = 0; k < terms.size(); ++k)
    if (k != skip) searched += variant_of(p_, terms[k]).searched;
  Model m = model_of(base_, GroupedBase::all, term_columns(terms, skip), searched, y_);
  models_.remember(key, terms, m, m.bytes());
  return m;
}

HeldOut Selection::heldout(const std::vector<Term>& terms, std::size_t skip, std::size_t trial,
                           const Variant* fixed) const {
  if (trial != none) return fits_.heldout(terms, skip, trial, fixed);
  const auto key = VariantSetCache<HeldOut>::key_of(p_, terms, skip);
  if (const HeldOut* cached = heldouts_.find(key)) return *cached;
  HeldOut h = fits_.heldout(terms, skip, none, nullptr);
  heldouts_.remember(key, terms, h, 0);
  return h;
}

Trial Selection::trial(std::size_t c, const std::vector<Term>& terms, const Model& cur) const {
  const Candidate& cand = p_.candidates[c];
  Trial t;
  t.cand = c;
  t.pool = generated(cand, cur.residual, std::vector<bool>(n_, true), n_);
  const auto& variants = listed(cand, t.pool);
  const Choice ch = choose(variants, allowed(p_, c, variants, terms, none), cur, choose_buffer_);
  if (ch.index == none) return t;
  t.index = ch.index;
  t.ext = ch.ext;
  const auto m = static_cast<double>(n_);
  const auto& v = variants[t.index];
  t.delta_bic =
      bic_of(ch.ext.rss, static_cast<double>(cur.rank + ch.ext.rank + cur.searched + v.searched), m) - cur.bic;
  t.bonferroni = static_cast<double>(cand.search_size ? cand.search_size : std::max<std::size_t>(variants.size(), 1));
  const double q = static_cast<double>(ch.ext.rank), dof2 = m - static_cast<double>(cur.rank + ch.ext.rank);
  t.p = f_test(cur.rss, ch.ext.rss, q, dof2, m);
  return t;
}

bool Selection::rechoose(std::vector<Term>& terms, std::size_t k) const {
  Term& t = terms[k];
  const Candidate& cand = p_.candidates[t.cand];
  if (!cand.generate && cand.variants.size() < 2) return false;
  const Model without = model(terms, k);
  auto pool = generated(cand, without.residual, std::vector<bool>(n_, true), n_);
  const auto& variants = listed(cand, pool);
  const Choice ch = choose(variants, allowed(p_, t.cand, variants, terms, k), without, choose_buffer_);
  if (ch.index == none) return false;
  Eigen::MatrixXd now_scratch, before_scratch;
  const auto rows = static_cast<Eigen::Index>(n_);
  const Eigen::MatrixXd& now = columns_of(variants[ch.index], rows, now_scratch);
  const Eigen::MatrixXd& before = columns_of(variant_of(p_, t), rows, before_scratch);
  if (now.cols() == before.cols() && (now - before).cwiseAbs().maxCoeff() <= 1e-12 * (1 + before.cwiseAbs().maxCoeff()))
    return false;
  t.pool = pool;
  t.index = ch.index;
  fits_.refold(terms, k);
  return true;
}

// Two effects whose shapes overlap (a deadband taken up late and a reversal spike) can each be the best given
// the other while another pair fits better, and re-choosing one at a time stays there.
bool Selection::rechoose_pair(std::vector<Term>& terms, std::size_t i, std::size_t j) const {
  const Candidate& ci = p_.candidates[terms[i].cand];
  const Candidate& cj = p_.candidates[terms[j].cand];
  if ((!ci.generate && ci.variants.size() < 2) || (!cj.generate && cj.variants.size() < 2)) return false;
  // Terms that share (almost) nothing cannot stand in for each other: not searched (a deadband and a
  // spike share 0.17; most pairs of the scenario suite below 0.03).
  Eigen::MatrixXd scratch_i, scratch_j;
  const auto rows = static_cast<Eigen::Index>(n_);
  if (overlap(columns_of(variant_of(p_, terms[i]), rows, scratch_i),
              columns_of(variant_of(p_, terms[j]), rows, scratch_j)) < 0.1)
    return false;
  const auto pool_i = generated(ci, model(terms, i).residual, std::vector<bool>(n_, true), n_);
  const auto& vi = listed(ci, pool_i);
  const std::vector<bool> ok = allowed(p_, terms[i].cand, vi, terms, i);
  std::vector<Term> trial = terms;
  double best = model(terms).bic;
  std::optional<std::pair<Term, Term>> better;
  for (std::size_t v = 0; v < vi.size(); ++v) {
    if (!ok[v]) continue;
    trial[i].pool = pool_i;
    trial[i].index = v;
    std::size_t searched = 0;
    for (std::size_t k = 0; k < trial.size(); ++k)
      if (k != j) searched += variant_of(p_, trial[k]).searched;
    const Model without_j = model_of(base_, GroupedBase::all, term_columns(trial, j), searched, y_);  // not cached
    const auto pool_j = generated(cj, without_j.residual, std::vector<bool>(n_, true), n_);
    const auto& vj = listed(cj, pool_j);
    const Choice ch = choose(vj, allowed(p_, trial[j].cand, vj, trial, j), without_j, choose_buffer_);
    if (ch.index == none) continue;
    const double bic =
        bic_of(ch.ext.rss, static_cast<double>(without_j.rank + ch.ext.rank + searched + vj[ch.index].searched),
               static_cast<double>(n_));
    if (bic < best - 1e-9 * std::abs(best)) {
      best = bic;
      Term tj = trial[j];
      tj.pool = pool_j;
      tj.index = ch.index;
      better.emplace(trial[i], std::move(tj));
    }
  }
  if (!better) return false;
  terms[i] = std::move(better->first);
  terms[j] = std::move(better->second);
  fits_.refold(terms, i);
  fits_.refold(terms, j);
  return true;
}

}  // namespace guideway::models::explain::engine
