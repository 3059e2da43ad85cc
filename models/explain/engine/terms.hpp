#pragma once
// The selection's vocabulary (models/explain/engine): an effect in the model (Term: its candidate, its variant,
// its columns in every fold), a candidate tried against the model (Trial), a term's drop-one test (DropTest),
// a held-out figure (HeldOut), and the variants a candidate offers against a residual. Pure functions; thread
// safe.

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "models/common/least_squares.hpp"
#include "models/explain/engine/folds.hpp"
#include "models/explain/engine/model_fit.hpp"
#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

// An effect in the model: its candidate, the variant chosen on all the data and, per fold, the columns
// of the variant chosen again on the fold's training rows (docs/explain.md "Held out").
struct Term {
  std::size_t cand = 0;
  std::shared_ptr<const std::vector<Variant>> pool;  // generated variants (null: the candidate's list)
  std::size_t index = 0;                             // the variant in the list
  double bonferroni = 1.0;                           // candidates x variants searched when it was taken
  std::size_t taken = 0;                             // when it was taken (findings are in this order)
  std::vector<FoldBlock> folds;
};

// A candidate's variants: the generated pool, or its list when it generates none.
const std::vector<Variant>& listed(const Candidate& c, const std::shared_ptr<const std::vector<Variant>>& pool);
const Variant& variant_of(const Problem& p, const Term& t);

// The candidate's variants for a residual (zero on the rows not in use), each checked to have n rows; null
// when the candidate generates none (its list is fixed).
std::shared_ptr<const std::vector<Variant>> generated(const Candidate& c, const Eigen::VectorXd& residual_um,
                                                      const std::vector<bool>& use, std::size_t n);

// A variant may join the model when its candidate has no term yet (skip aside), or when every term of its
// candidate is of another, named group (a cyclic error on the other axis, a vibration along another direction).
bool group_free(const Problem& p, const Variant& v, std::size_t cand, const std::vector<Term>& terms, std::size_t skip);
// group_free of each variant of the list.
std::vector<bool> allowed(const Problem& p, std::size_t cand, const std::vector<Variant>& variants,
                          const std::vector<Term>& terms, std::size_t skip);

struct HeldOut {
  double rms = nan;
  std::string failure;           // why rms is NaN: a fold could not be fitted (not skipped: every figure
                                 // compared must average the same rows)
  std::vector<FoldBlock> trial;  // the trial's columns per fold (its term's when it is taken)
};

// A candidate tried against the model: its best variant, the joint fit and the tests of explain().
struct Trial {
  std::size_t cand = 0;
  std::shared_ptr<const std::vector<Variant>> pool;
  std::size_t index = none;
  Extension ext;
  double delta_bic = 0, p = 1, bonferroni = 1;
};

// Whether a term still earns its place in the model: the F-test, BIC and held-out RMS of the model
// without it against the model with it.
struct DropTest {
  double p = 1, delta_bic = 0, heldout_without = nan;
  bool earns = false;
  std::string why;  // when it does not
};

// A variant's reported parameters from a joint fit whose coefficients of its block start at `offset`.
std::vector<ParamValue> params_of(const Variant& v, const LsqResult& f, Eigen::Index offset);

}  // namespace guideway::models::explain::engine
