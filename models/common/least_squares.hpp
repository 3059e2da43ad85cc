#pragma once
// Weighted linear least squares with the diagnostics an identification needs: parameter standard
// uncertainties from s^2 (J^T W J)^-1, the condition number of the column-scaled problem, and an
// SVD rank analysis that names the parameters the data cannot separate instead of returning
// meaningless numbers. Solved by Householder QR of the weighted, column-scaled Jacobian followed by
// an SVD of R (never the normal equations). Pure functions; thread safe.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "models/common/householder_triangle.hpp"
#include "models/common/lsq_combination.hpp"

namespace guideway::models {

struct LsqOptions {
  // A singular value below rank_tolerance * largest (column-scaled problem) counts as zero.
  double rank_tolerance = 1e-9;
  // A parameter whose weight in a null-space direction exceeds this is "not separable".
  double null_loading = 0.05;
};

struct LsqResult {
  bool ok = false;  // false: message says why (too few points, non-finite input)
  std::string message;
  Eigen::VectorXd x;           // estimates; 0 for unidentifiable parameters
  Eigen::VectorXd u;           // standard uncertainties; NaN for unidentifiable parameters
  Eigen::MatrixXd covariance;  // of the identified parameters (zero rows/cols for the others)
  std::vector<bool> identified;
  std::vector<std::string> unidentifiable;   // names, in parameter order
  std::vector<LsqCombination> combinations;  // what the data says about the unidentifiable ones
  Eigen::VectorXd residual;                  // y - J fitted (unweighted)
  Eigen::VectorXd fitted;                    // the solution behind `residual`: like x, but parameters kept
                                             // to stand for a combination carry their combined value
  double s2 = 0.0;                           // weighted residual variance r^T W r / (n - rank)
  double rms = 0.0;                          // unweighted residual rms
  double condition_number = 0.0;             // of the column-scaled weighted Jacobian (all parameters)
  std::size_t n = 0;
  std::size_t rank = 0;
};

// Minimises sum w_i (y_i - J_i x)^2. `weights` may be empty (all 1). `names` labels the columns.
// `jacobian` may be a block of a larger matrix (a caller's reused buffer): it is not copied.
LsqResult solve_lsq(const Eigen::Ref<const Eigen::MatrixXd>& jacobian, const Eigen::VectorXd& y, const Eigen::VectorXd& weights,
                    const std::vector<std::string>& names, const LsqOptions& options = {});
// The same of J = [blocks...] (householder_triangle.hpp): the same triangle, so the same solution, as of J copied
// into one matrix, without that n x m copy (the residual's sums taken block by block).
LsqResult solve_lsq(const ColumnBlocks& jacobian, const Eigen::VectorXd& y, const Eigen::VectorXd& weights,
                    const std::vector<std::string>& names, const LsqOptions& options = {});

}  // namespace guideway::models
