#pragma once
// The weighted least squares of the map's fit (models/map/fit.cpp): every observation group's normal
// equations on the map's columns and its own set-up terms, the readings linearised at the parameters, the
// solution on the columns chosen (a direction no test sees is dropped, not inverted), each group's variance
// factor from its own residuals, and the functions' columns in the layout of their highest orders.
// Internal to models/map; thread safe (pure functions of their arguments).

#include <cstddef>
#include <memory>
#include <vector>

#include <Eigen/Dense>

#include "models/map/error_map.hpp"
#include "models/map/fit.hpp"
#include "models/map/fit_groups.hpp"
#include "models/map/map_inputs.hpp"

namespace guideway::models::map::detail {

inline Eigen::Index ix(std::size_t i) { return static_cast<Eigen::Index>(i); }

// ---- The normal equations of every group ----

struct Blocks {
  std::size_t p = 0;   // map parameters
  std::size_t nu = 0;  // every group's own terms
  std::vector<std::unique_ptr<Group>> groups;
  std::vector<std::size_t> first_nuisance;  // per group, global column
  std::vector<Eigen::MatrixXd> jac;         // per group: rows x (p + its nuisance)
  std::vector<Eigen::VectorXd> w;           // per group: 1 / sigma^2 of each reading (relative)
  std::vector<Eigen::MatrixXd> a;           // J^T W J, (p + its nuisance)^2
  std::vector<double> scale2;               // per group: estimated variance factor
  [[nodiscard]] std::size_t columns() const { return p + nu; }
  // Global column of a group's local column.
  [[nodiscard]] std::size_t global(std::size_t g, std::size_t local) const {
    return local < p ? local : first_nuisance[g] + (local - p);
  }
};

Blocks make_blocks(const MapInputs& in, const ErrorMap& m, const FitOptions& o, const DeadbandWidths& deadbands = {});

// A group's columns of the global parameters: the map's, then its own.
Eigen::VectorXd local_theta(const Blocks& b, std::size_t g, const Eigen::VectorXd& theta);

// The linearised readings at parameters theta (global): y - f(theta) + J theta, per group.
std::vector<Eigen::VectorXd> pseudo_readings(const Blocks& b, ErrorMap& m, const Eigen::VectorXd& theta);

// The normal equations of every group together (with the groups' estimated scales), on all columns.
struct Normal {
  Eigen::MatrixXd n;
  Eigen::VectorXd rhs;
  double yy = 0.0;  // sum of the weighted squared readings
};

Normal normal_of(const Blocks& b, const std::vector<Eigen::VectorXd>& y, const std::vector<bool>& use_group = {});

// chi2 (with the scales) of the least-squares solution on `cols`: yy - b' N^-1 b, by Cholesky of the scaled
// normal matrix (the order search's many small solves).
double chi2_on(const Normal& nm, const std::vector<std::size_t>& cols);

// The solution on the selected columns (global, ascending) and what goes with it.
struct Solution {
  std::vector<std::size_t> cols;
  Eigen::VectorXd theta;            // global length, zero outside cols
  Eigen::MatrixXd inverse;          // of the normal matrix on cols (the covariance, with the estimated scales)
  std::vector<double> chi2;         // per group, relative weights (sum w r^2 without the scale)
  std::vector<double> trace;        // per group: its share of the fitted parameters
  std::size_t rank_deficiency = 0;  // directions the tests cannot see, left out
};

Solution solve(const Blocks& b, const std::vector<Eigen::VectorXd>& y, const std::vector<std::size_t>& cols,
               const std::vector<bool>& use_group = {});

// Each group's variance factor from its own residuals: chi2 / (readings - its share of the parameters).
void update_scales(Blocks& b, const Solution& s);

// ---- The functions' columns in the max-order layout ----

struct FunctionColumns {
  int axis = 0, component = 0;
  std::size_t first = 0;  // global column of its lowest order
  int lowest = 1, highest = 1;
  int chosen = 1;
  double bic_n = 1.0;  // observations that see it (BIC's n)
};

// The columns of every function the map fits, each at its highest order (chosen = highest).
std::vector<FunctionColumns> function_columns(const ErrorMap& m);

// The columns of the functions at their chosen orders, the fitted squarenesses and every group's own terms.
std::vector<std::size_t> selected_columns(const Blocks& b, const std::vector<FunctionColumns>& fc, const ErrorMap& m);

// What the fit (fit.cpp's fit_core) leaves: every group's equations and linearised readings, and the solution.
struct Fitted {
  Blocks b;
  std::vector<Eigen::VectorXd> y;
  Solution s;
  std::vector<long> where;  // position of each global column in s.cols (-1: not fitted)
};

}  // namespace guideway::models::map::detail
