// The selection's vocabulary (terms.hpp).
#include "models/explain/engine/terms.hpp"

#include <stdexcept>

namespace guideway::models::explain::engine {

const std::vector<Variant>& listed(const Candidate& c, const std::shared_ptr<const std::vector<Variant>>& pool) {
  return pool ? *pool : c.variants;
}
const Variant& variant_of(const Problem& p, const Term& t) { return listed(p.candidates[t.cand], t.pool)[t.index]; }

std::shared_ptr<const std::vector<Variant>> generated(const Candidate& c, const Eigen::VectorXd& residual_um,
                                                      const std::vector<bool>& use, std::size_t n) {
  if (!c.generate) return nullptr;
  auto pool = std::make_shared<const std::vector<Variant>>(c.generate(residual_um, use));
  for (const auto& v : *pool)
    if (!v.fill && static_cast<std::size_t>(v.block.columns.rows()) != n)
      throw std::invalid_argument("explain: candidate " + c.effect + " has the wrong number of rows");
  return pool;
}

bool group_free(const Problem& p, const Variant& v, std::size_t cand, const std::vector<Term>& terms,
                std::size_t skip) {
  for (std::size_t k = 0; k < terms.size(); ++k) {
    if (k == skip || terms[k].cand != cand) continue;
    if (v.group.empty() || variant_of(p, terms[k]).group == v.group) return false;
  }
  return true;
}

std::vector<bool> allowed(const Problem& p, std::size_t cand, const std::vector<Variant>& variants,
                          const std::vector<Term>& terms, std::size_t skip) {
  std::vector<bool> a(variants.size());
  for (std::size_t v = 0; v < variants.size(); ++v) a[v] = group_free(p, variants[v], cand, terms, skip);
  return a;
}

std::vector<ParamValue> params_of(const Variant& v, const LsqResult& f, Eigen::Index offset) {
  const auto q = width(v);
  Eigen::VectorXd x = f.x.segment(offset, q);
  Eigen::MatrixXd cov = f.covariance.block(offset, offset, q, q);
  std::vector<ParamValue> out;
  if (v.report) {
    out = v.report(x, cov);
  } else {
    for (Eigen::Index i = 0; i < q; ++i)
      out.push_back({v.block.names[static_cast<std::size_t>(i)], x[i], f.u[offset + i]});
  }
  out.insert(out.end(), v.fixed.begin(), v.fixed.end());
  return out;
}

}  // namespace guideway::models::explain::engine
