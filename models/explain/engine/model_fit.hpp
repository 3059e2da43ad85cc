#pragma once
// EXPLAIN's models (models/explain/engine): the least squares of the base and a few terms kept as an orthonormal
// basis of its span and its residual, a variant tried against it exactly and cheaply (extend, choose), and the BIC
// and F-test the selection decides by. Pure functions; not thread safe (the grouped base's row sets).

#include <cstddef>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "models/explain/engine/grouped_base.hpp"
#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

inline constexpr double nan = std::numeric_limits<double>::quiet_NaN();
inline constexpr std::size_t none = static_cast<std::size_t>(-1);

// The BIC of a fit with residual sum of squares rss, k parameters and m samples (n ln RSS/n + k ln n), the RSS
// floored at the finest level the tests resolve.
double bic_of(double rss, double k, double m);

// F-test of the columns that take a model's RSS from rss0 to rss1 (q more rank, dof1 residual degrees of
// freedom left): the survival probability.
double f_test(double rss0, double rss1, double q, double dof1, double m);

// The least squares of a model -- the base and a few terms' columns -- on the rows of every group of the grouped
// base but one (a fold's training rows) or on every row: an orthonormal basis of its span, the base's part shared
// (grouped_base.hpp) and its terms' part its own, and its residual, so that a variant can be tried against it
// exactly and cheaply (extend()). Vectors and columns have every row of the problem; the model's residual and its
// terms' part are 0 on the rows it leaves out.
struct Model {
  const GroupedBase* base = nullptr;
  std::size_t skip = GroupedBase::all;  // its rows: every group's but this one's
  Eigen::MatrixXd qt;                   // n x k: the terms' part of the basis, orthogonal to the base's span
  Eigen::VectorXd residual;
  double rss = 0;
  std::size_t rank = 0;
  std::size_t searched = 0;  // nonlinear parameters found by search (counted in the BIC)
  double bic = 0;
  [[nodiscard]] std::size_t bytes() const {
    return static_cast<std::size_t>(qt.size() + residual.size()) * sizeof(double);
  }
};
// The base and `terms` (n x k) on the rows of every group but `skip`, fitted to y (its rows only count).
Model model_of(const GroupedBase& base, std::size_t skip, Eigen::MatrixXd terms, std::size_t searched,
               const Eigen::VectorXd& y);
// Q^T x for the model's basis Q (the base's part first), and x - Q c on the model's rows (x: every row).
Eigen::MatrixXd project(const Model& m, const Eigen::Ref<const Eigen::MatrixXd>& x);
void subtract(const Model& m, const Eigen::Ref<const Eigen::MatrixXd>& c, Eigen::Ref<Eigen::MatrixXd> x);

// The joint least squares of a model and the columns x (every row; only the model's count), from the model's basis
// and residual: x is projected off the model's span, and what is left of the residual in the span of the rest is
// removed.
struct Extension {
  double rss = 0;
  std::size_t rank = 0;  // added to the model's
};
Extension extend(const Model& m, Eigen::MatrixXd x);

// A candidate's best variant against a model on its rows: the exact joint fit of each allowed variant,
// lowest BIC (n ln RSS + (rank + searched) ln n). none: no variant can be fitted.
struct Choice {
  std::size_t index = none;
  Extension ext;
};
// `buffer` holds a batch's columns between calls: at large n a fresh n x 64 batch is an allocation the kernel
// clears page by page every time.
Choice choose(const std::vector<Variant>& variants, const std::vector<bool>& allowed, const Model& m,
              std::vector<double>& buffer);

}  // namespace guideway::models::explain::engine
