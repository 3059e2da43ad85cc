#pragma once
// EXPLAIN's models (models/explain/engine): the least squares of a design kept as an orthonormal basis of its
// span and its residual, a variant tried against it exactly and cheaply (extend, choose), and the BIC and
// F-test the selection decides by. Pure functions; thread safe.

#include <cstddef>
#include <limits>
#include <vector>

#include <Eigen/Core>

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

// The least squares of a model on some rows, kept as an orthonormal basis of its columns and its residual,
// so that a variant can be tried against it exactly and cheaply (extend()).
struct Model {
  Eigen::MatrixXd q;
  Eigen::VectorXd residual;
  double rss = 0;
  std::size_t rank = 0;
  std::size_t searched = 0;  // nonlinear parameters found by search (counted in the BIC)
  double bic = 0;
};
Model model_of(Eigen::MatrixXd j, std::size_t searched, const Eigen::VectorXd& y);

// The joint least squares of a model and the columns x (same rows), from the model's basis and residual:
// x is projected off the model's span, and what is left of the residual in the span of the rest is removed.
struct Extension {
  double rss = 0;
  std::size_t rank = 0;  // added to the model's
};
Extension extend(const Model& m, const Eigen::MatrixXd& x);

// A candidate's best variant against a model on some rows: the exact joint fit of each allowed variant,
// lowest BIC (n ln RSS + (rank + searched) ln n). rows = null: all rows. none: no variant can be fitted.
struct Choice {
  std::size_t index = none;
  Extension ext;
};
// `buffer` holds a batch's columns between calls: at large n a fresh n x 64 batch is an allocation the kernel
// clears page by page every time.
Choice choose(const std::vector<Variant>& variants, const std::vector<bool>& allowed,
              const std::vector<Eigen::Index>* rows, const Model& m, std::vector<double>& buffer);

}  // namespace guideway::models::explain::engine
