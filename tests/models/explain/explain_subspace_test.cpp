// EXPLAIN's least squares on tall designs (models/explain/engine/subspace.hpp): the factor of a matrix given a chunk
// of rows at a time is the factor of the whole, and a subset's fit read from it is the direct least-squares fit of
// those columns (Eigen's complete orthogonal decomposition of the whole n-row design, another algorithm), rank
// included, where a column of the subset is a combination of the others.
#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/QR>
#include <gtest/gtest.h>

#include "models/explain/engine/subspace.hpp"

using namespace guideway::models::explain::engine;

namespace {

Eigen::MatrixXd random_design(Eigen::Index n, Eigen::Index p, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  Eigen::MatrixXd a(n, p);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < p; ++j) a(i, j) = g(rng) * std::pow(10.0, static_cast<double>(j % 4) - 2);
  return a;
}

// The direct fit: residual sum of squares and rank of y on the columns, scaled to unit norm as EXPLAIN scales them.
ColumnsFit direct_fit(const Eigen::MatrixXd& x, const Eigen::VectorXd& y) {
  Eigen::MatrixXd s = x;
  for (Eigen::Index c = 0; c < s.cols(); ++c) s.col(c) /= s.col(c).norm();
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod;
  cod.setThreshold(rank_tolerance);
  cod.compute(s);
  const Eigen::VectorXd b = cod.solve(y);
  return {(y - s * b).squaredNorm(), cod.rank()};
}

}  // namespace

TEST(ExplainSubspace, TheFactorOfRowsGivenInChunksIsTheWholeMatrixsFactor) {
  const Eigen::Index n = 70'001, w = 7;  // several of tall_r's chunks, the last one short
  const Eigen::MatrixXd a = random_design(n, w - 1, 3);
  const Eigen::VectorXd y = random_design(n, 1, 4).col(0);
  const Eigen::MatrixXd whole = tall_r(a, &y);
  const Eigen::MatrixXd rows = tall_r_rows(n, w, [&](Eigen::Index from, Eigen::Ref<Eigen::MatrixXd> part) {
    part.leftCols(w - 1) = a.middleRows(from, part.rows());
    part.col(w - 1) = y.segment(from, part.rows());
  });
  ASSERT_EQ(rows.rows(), w);
  EXPECT_EQ((rows - whole).cwiseAbs().maxCoeff(), 0.0);  // the same operations, in the same order
  // And R^T R is the Gram matrix of [a y].
  Eigen::MatrixXd ay(n, w);
  ay << a, y;
  const Eigen::MatrixXd gram = ay.transpose() * ay;
  EXPECT_LT((rows.transpose() * rows - gram).cwiseAbs().maxCoeff() / gram.cwiseAbs().maxCoeff(), 1e-12);
}

TEST(ExplainSubspace, ASubsetsFitFromTheFactorIsTheDirectFitOfThoseColumns) {
  const Eigen::Index n = 5'000;
  Eigen::MatrixXd a = random_design(n, 6, 7);
  a.col(5) = 2.0 * a.col(1) - 0.5 * a.col(3);  // in the span of columns 1 and 3
  Eigen::VectorXd y = a.col(0) * 0.3 + a.col(3) * 4.0 + random_design(n, 1, 8).col(0);
  const Eigen::MatrixXd r = tall_r(a, &y);
  const std::vector<std::vector<Eigen::Index>> subsets = {{}, {0}, {0, 2}, {1, 3, 5}, {0, 1, 2, 3, 4, 5}, {4, 1}};
  for (const auto& cols : subsets) {
    Eigen::MatrixXd x(n, static_cast<Eigen::Index>(cols.size()));
    for (std::size_t j = 0; j < cols.size(); ++j) x.col(static_cast<Eigen::Index>(j)) = a.col(cols[j]);
    const ColumnsFit got = fit_of_columns(r, cols);
    const ColumnsFit want = cols.empty() ? ColumnsFit{y.squaredNorm(), 0} : direct_fit(x, y);
    EXPECT_EQ(got.rank, want.rank) << cols.size() << " columns";
    EXPECT_NEAR(got.rss / want.rss, 1.0, 1e-9) << cols.size() << " columns";
  }
  // The dependent column adds no rank: {1, 3, 5} has rank 2 and fits y as {1, 3} does.
  EXPECT_EQ(fit_of_columns(r, {1, 3, 5}).rank, 2);
  EXPECT_NEAR(fit_of_columns(r, {1, 3, 5}).rss / fit_of_columns(r, {1, 3}).rss, 1.0, 1e-12);
}
