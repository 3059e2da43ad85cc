#pragma once
// Whether a term of EXPLAIN's selection still earns its place (models/explain/engine, docs/explain.md "Name and
// fit"): its F-test and BIC against the model without it, the held-out RMS without it, the share of the structure
// left without it that it removes, and its parameters' u widened over the searched values the data leave
// plausible. Not thread safe (the selection's caches).

#include <cstddef>
#include <string>
#include <vector>

#include "models/explain/engine/model_fit.hpp"
#include "models/explain/engine/selection.hpp"
#include "models/explain/engine/terms.hpp"
#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

// Term k against the model without it: the F-test (Bonferroni as when it was taken) and the BIC.
DropTest significance(const Selection& sel, const std::vector<Term>& terms, std::size_t k, const Model& cur);

// Why variant v, fitted beside the model `without` to a joint RSS `rss`, is not taken for a searched value at an end
// of its grid: a variant a step past that end (Variant::beyond) fits better beside the same model, so the optimum
// lies outside the grid. "" when none does (or v has none).
std::string past_grid_edge(const Selection& sel, const Model& without, const Variant& v, double rss);

// Does term k still earn its place with the others in the model (`cur`, held-out cur_heldout)? Not where its
// variant, chosen again, is at its grid's edge with the optimum past it (past_grid_edge).
DropTest drop_test(const Selection& sel, const std::vector<Term>& terms, std::size_t k, const Model& cur,
                   double cur_heldout);

// Term k's parameters, their u widened by the searched parameters' uncertainty: over every other variant
// of its list that the data leave plausible -- the joint RSS within s^2 of the chosen one, the 1-sigma
// region of the profile likelihood -- the largest change of each parameter is added in quadrature.
// (u from the covariance alone is conditional on the searched value: a spike's decay one grid step off
// halves its amplitude.)
std::vector<ParamValue> widened(const Selection& sel, const std::vector<Term>& terms, std::size_t k, const Model& cur,
                                const std::vector<ParamValue>& chosen);

// Share of the structure left without term k that the model with it removes: visible energy of the
// bands located in the residual without it, against that of the residual with it. NaN when nothing is
// structured without it (a term below visibility is judged by the tests alone).
double share(const Selection& sel, const std::vector<Term>& terms, std::size_t k, const Model& cur, double sigma,
             double floor);

}  // namespace guideway::models::explain::engine
