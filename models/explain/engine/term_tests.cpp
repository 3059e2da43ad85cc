// Whether a term of EXPLAIN's selection still earns its place (term_tests.hpp).
#include "models/explain/engine/term_tests.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/number_format.hpp"
#include "models/common/least_squares.hpp"
#include "models/explain/locate.hpp"

namespace guideway::models::explain::engine {

DropTest significance(const Selection& sel, const std::vector<Term>& terms, std::size_t k, const Model& cur) {
  DropTest d;
  const Model without = sel.model(terms, k);
  const auto m = static_cast<double>(sel.observations().size());
  const double q = static_cast<double>(cur.rank) - static_cast<double>(without.rank);
  const double dof2 = m - static_cast<double>(cur.rank);
  d.p = std::min(1.0, f_test(without.rss, cur.rss, q, dof2, m) * terms[k].bonferroni);
  d.delta_bic = cur.bic - without.bic;
  return d;
}

namespace {

// `without` with variant v's columns beside it.
Extension extended_by(const Selection& sel, const Model& without, const Variant& v) {
  Eigen::MatrixXd x(static_cast<Eigen::Index>(sel.observations().size()), width(v));
  write_columns(v, x);
  return extend(without, std::move(x));
}

}  // namespace

std::string past_grid_edge(const Selection& sel, const Model& without, const Variant& v, double rss) {
  for (const Variant& b : v.beyond) {
    const Extension e = extended_by(sel, without, b);
    // Better beyond rounding: the joint fits of `v` and of `b` come by different routes (choose(), extend()).
    if (e.rank == 0 || !(e.rss < rss * (1 - 1e-9))) continue;
    std::string at, past;
    for (std::size_t i = 0; i < v.fixed.size() && i < b.fixed.size(); ++i)
      if (v.fixed[i].value != b.fixed[i].value) {
        at = v.fixed[i].name + " = " + printf_number("%.4g", v.fixed[i].value);
        past = printf_number("%.4g", b.fixed[i].value);
      }
    return "its searched " + at + " is at its grid's edge and " + past +
           ", past it, fits better: the optimum lies outside the grid";
  }
  return "";
}

DropTest drop_test(const Selection& sel, const std::vector<Term>& terms, std::size_t k, const Model& cur,
                   double cur_heldout) {
  DropTest d = significance(sel, terms, k, cur);
  if (!(d.p < sel.options().alpha)) {
    d.why = "not significant with the others in the model (p=" + printf_number("%.2g", d.p) + ")";
    return d;
  }
  if (!(d.delta_bic < 0)) {
    d.why = "does not lower the BIC with the others in the model";
    return d;
  }
  if (std::string edge = past_grid_edge(sel, sel.model(terms, k), variant_of(sel.problem(), terms[k]), cur.rss);
      !edge.empty()) {
    d.why = std::move(edge);
    return d;
  }
  d.heldout_without = sel.heldout(terms, k).rms;
  if (std::isfinite(cur_heldout) && std::isfinite(d.heldout_without) && !(cur_heldout < d.heldout_without)) {
    d.why = "the held-out RMS is no worse without it (" + printf_number("%.4g", d.heldout_without) + " um)";
    return d;
  }
  d.earns = true;
  return d;
}

std::vector<ParamValue> widened(const Selection& sel, const std::vector<Term>& terms, std::size_t k, const Model& cur,
                                const std::vector<ParamValue>& chosen) {
  const Problem& p = sel.problem();
  const Term& t = terms[k];
  const auto& variants = listed(p.candidates[t.cand], t.pool);
  if (variants.size() < 2) return chosen;
  const auto n = static_cast<double>(sel.observations().size());
  const double s2 = cur.rss / std::max(1.0, n - static_cast<double>(cur.rank));
  const Model without = sel.model(terms, k);
  const auto ok = allowed(p, t.cand, variants, terms, k);
  std::vector<ParamValue> out = chosen;
  std::vector<double> spread(out.size(), 0.0);
  for (std::size_t v = 0; v < variants.size(); ++v) {
    if (v == t.index || !ok[v]) continue;
    const Extension e = extended_by(sel, without, variants[v]);
    if (e.rank == 0 || !(e.rss - cur.rss < s2)) continue;
    std::vector<Term> alt = terms;
    alt[k].index = v;
    const LsqResult fit = sel.fit(alt);
    if (!fit.ok) continue;
    Eigen::Index offset = p.base.columns.cols();
    for (std::size_t j = 0; j < k; ++j) offset += width(variant_of(p, terms[j]));
    for (const ParamValue& q : params_of(variants[v], fit, offset))
      for (std::size_t i = 0; i < out.size(); ++i)
        if (out[i].name == q.name && std::isfinite(out[i].u))
          spread[i] = std::max(spread[i], std::abs(q.value - out[i].value));
  }
  for (std::size_t i = 0; i < out.size(); ++i) out[i].u = std::hypot(out[i].u, spread[i]);
  return out;
}

double share(const Selection& sel, const std::vector<Term>& terms, std::size_t k, const Model& cur, double sigma,
             double floor) {
  const Problem& p = sel.problem();
  const Model without = sel.model(terms, k);
  const Located here = locate(p, without.residual, sel.options().alpha, sigma);
  if (!here.structured) return nan;
  const double before = visible_energy(p, without.residual, sigma, here.flagged);
  if (!(before > floor)) return nan;
  return 1.0 - visible_energy(p, cur.residual, sigma, here.flagged) / before;
}

}  // namespace guideway::models::explain::engine
