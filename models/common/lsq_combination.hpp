#pragma once
// What a least-squares fit says about parameters it cannot separate: a combination of them that the data
// does determine (solve_lsq reports them; the identifications keep them in their results). Without Eigen,
// so the results' headers stay light.

#include <cstddef>
#include <string>
#include <vector>

namespace guideway::models {

// A linear combination of parameters that the data does determine, reported when some parameters
// are not separable: value = sum coefficient[i] * parameter[index[i]].
struct LsqCombination {
  std::string expression;  // e.g. "c0_plus_d1 + 9025*c2" (coefficients in the parameters' own units)
  std::vector<std::size_t> index;
  std::vector<double> coefficient;
  double value = 0.0;
  double u = 0.0;
};

}  // namespace guideway::models
