// models/common/householder_triangle (the QR behind solve_lsq): the triangle against numpy's
// LAPACK QR (/usr/bin/python3, tests/models/common/lsq_triangle_oracle.py) and Eigen's Householder QR, and the
// SSE2 and AVX2 kernels against each other bit for bit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>

#include <Eigen/QR>

#include "models/common/householder_triangle.hpp"
#include "models/common/least_squares.hpp"
#include "test_support.hpp"

namespace {

using guideway::models::householder_avx2_available;
using guideway::models::TriangleKernel;
using guideway::models::weighted_triangle;

struct Problem {
  Eigen::MatrixXd a;
  Eigen::VectorXd y, w;
};

// Badly scaled columns (1e3 .. 1e-3 and beyond), positive weights, a zero weight and a zero column.
Problem random_problem(Eigen::Index n, Eigen::Index m, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> nd;
  Problem p{Eigen::MatrixXd(n, m), Eigen::VectorXd(n), Eigen::VectorXd(n)};
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index c = 0; c < m; ++c) p.a(i, c) = nd(rng) * std::pow(10.0, 3.0 - 0.5 * static_cast<double>(c));
    p.y[i] = nd(rng);
    p.w[i] = 0.25 + std::abs(nd(rng));
  }
  if (n > 3) p.w[2] = 0.0;
  return p;
}

// R with its rows' signs chosen so that the diagonal is non-negative (R is unique up to them).
Eigen::MatrixXd positive_diagonal(Eigen::MatrixXd r) {
  for (Eigen::Index i = 0; i < r.rows(); ++i)
    if (r(i, i) < 0) r.row(i) *= -1.0;
  return r;
}

// Each column of `r` against `ref`, relative to the column's norm (the scale QR's rounding has).
void expect_same_triangle(const Eigen::MatrixXd& r, const Eigen::MatrixXd& ref, double tol, const char* what) {
  ASSERT_EQ(r.rows(), ref.rows());
  ASSERT_EQ(r.cols(), ref.cols());
  for (Eigen::Index c = 0; c < r.cols(); ++c) {
    const double norm = ref.col(c).norm();
    for (Eigen::Index i = 0; i < r.rows(); ++i)
      EXPECT_NEAR(r(i, c), ref(i, c), tol * norm) << what << " R(" << i << "," << c << ")";
  }
}

bool have_numpy() { return std::system("/usr/bin/python3 -c 'import numpy' >/dev/null 2>&1") == 0; }

TEST(LsqTriangleTest, MatchesNumpyAndEigenQr) {
  // 5003 rows: several chunks and a last one that is not a multiple of 4.
  const Problem p = random_problem(5003, 20, 3);
  const Eigen::MatrixXd r = positive_diagonal(weighted_triangle(p.a, p.y, p.w.cwiseSqrt()));
  // R^T R = [A y]^T W [A y], whatever the signs.
  Eigen::MatrixXd ay(p.a.rows(), p.a.cols() + 1);
  ay << p.a, p.y;
  const Eigen::MatrixXd wa = p.w.cwiseSqrt().asDiagonal() * ay;
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(wa);
  const Eigen::MatrixXd eig = positive_diagonal(qr.matrixQR().topRows(ay.cols()).triangularView<Eigen::Upper>());
  expect_same_triangle(r, eig, 1e-12, "Eigen");
  if (!have_numpy()) GTEST_SKIP() << "/usr/bin/python3 with numpy is not available";
  guideway::test::TempDir dir;
  {
    std::ofstream in(dir.file("in.csv"));
    in.precision(17);
    for (Eigen::Index i = 0; i < p.a.rows(); ++i) {
      in << p.w[i] << "," << p.y[i];
      for (Eigen::Index c = 0; c < p.a.cols(); ++c) in << "," << p.a(i, c);
      in << "\n";
    }
  }
  const std::string cmd = "/usr/bin/python3 " GUIDEWAY_SOURCE_DIR "/tests/models/common/lsq_triangle_oracle.py " +
                          dir.file("in.csv") + " " + dir.file("out.txt");
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream out(dir.file("out.txt"));
  Eigen::MatrixXd np(r.rows(), r.cols());
  for (Eigen::Index i = 0; i < np.rows(); ++i)
    for (Eigen::Index c = 0; c < np.cols(); ++c) ASSERT_TRUE(out >> np(i, c)) << "numpy triangle too short";
  expect_same_triangle(r, np, 1e-12, "numpy");
}

TEST(LsqTriangleTest, DegenerateShapes) {
  // A zero column stays zero (its reflector is the identity) and the rest is unaffected.
  Problem p = random_problem(41, 4, 5);
  p.a.col(1).setZero();
  const Eigen::MatrixXd r = weighted_triangle(p.a, p.y, p.w.cwiseSqrt());
  EXPECT_EQ(r.col(1).norm(), 0.0);
  EXPECT_EQ(r.row(1).norm(), 0.0);
  Eigen::MatrixXd ay(41, 5);
  ay << p.a, p.y;
  const Eigen::MatrixXd wa = p.w.cwiseSqrt().asDiagonal() * ay;
  EXPECT_LT((r.transpose() * r - wa.transpose() * wa).norm(), 1e-12 * (wa.transpose() * wa).norm());
  // Fewer rows than columns: R^T R still equals the Gram matrix.
  const Problem q = random_problem(3, 6, 6);
  const Eigen::MatrixXd rq = weighted_triangle(q.a, q.y, q.w.cwiseSqrt());
  Eigen::MatrixXd qy(3, 7);
  qy << q.a, q.y;
  const Eigen::MatrixXd wq = q.w.cwiseSqrt().asDiagonal() * qy;
  EXPECT_LT((rq.transpose() * rq - wq.transpose() * wq).norm(), 1e-12 * (wq.transpose() * wq).norm());
  EXPECT_TRUE(rq.isUpperTriangular(0.0));
}

TEST(LsqTriangleTest, KernelsGiveTheSameBits) {
  if (!householder_avx2_available()) {
    EXPECT_THROW((void)weighted_triangle(Eigen::MatrixXd::Ones(8, 2), Eigen::VectorXd::Ones(8),
                                         Eigen::VectorXd::Ones(8), TriangleKernel::avx2),
                 std::invalid_argument);
    GTEST_SKIP() << "no AVX2 on this CPU (or not an x86-64 GCC build): only the portable kernel runs";
  }
  const Eigen::Index shapes[][2] = {{1, 1}, {3, 5}, {7, 3}, {1000, 1}, {4099, 21}, {300, 40}, {10800, 20}};
  unsigned seed = 10;
  for (const auto& s : shapes) {
    const Problem p = random_problem(s[0], s[1], seed++);
    const Eigen::VectorXd sw = p.w.cwiseSqrt();
    const Eigen::MatrixXd a = weighted_triangle(p.a, p.y, sw, TriangleKernel::portable);
    const Eigen::MatrixXd b = weighted_triangle(p.a, p.y, sw, TriangleKernel::avx2);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())), 0)
        << s[0] << " x " << s[1] << ": max difference " << (a - b).cwiseAbs().maxCoeff();
  }
}

// A design given as blocks of its columns (a problem's base beside a fit's own columns) is solved as the same
// design copied into one matrix: the same triangle bit for bit, the same estimates, uncertainties and residual
// (its sums taken block by block: to rounding). Rank deficient too (a column repeated across the blocks).
TEST(LsqTriangleTest, ColumnBlocksAreTheMatrixTheyMakeUp) {
  const Eigen::Index shapes[][2] = {{40, 3}, {4099, 7}, {10800, 20}};
  unsigned seed = 30;
  for (const auto& s : shapes) {
    Problem p = random_problem(s[0], s[1], seed++);
    const Eigen::Index split = s[1] / 2 + 1;
    if (s[1] > 4) p.a.col(s[1] - 1) = p.a.col(0) * 2.0;  // the second block repeats a direction of the first
    const Eigen::MatrixXd left = p.a.leftCols(split), right = p.a.rightCols(s[1] - split);
    const guideway::models::ColumnBlocks blocks{left, right};
    const Eigen::VectorXd sw = p.w.cwiseSqrt();
    const Eigen::MatrixXd whole = weighted_triangle(p.a, p.y, sw), parts = weighted_triangle(blocks, p.y, sw);
    ASSERT_EQ(whole.size(), parts.size());
    EXPECT_EQ(std::memcmp(whole.data(), parts.data(), sizeof(double) * static_cast<std::size_t>(whole.size())), 0);
    std::vector<std::string> names;
    for (Eigen::Index c = 0; c < s[1]; ++c) names.push_back("p" + std::to_string(c));
    const auto a = guideway::models::solve_lsq(p.a, p.y, p.w, names);
    const auto b = guideway::models::solve_lsq(blocks, p.y, p.w, names);
    ASSERT_TRUE(a.ok && b.ok) << a.message << " / " << b.message;
    EXPECT_EQ(a.unidentifiable, b.unidentifiable);
    EXPECT_EQ(a.rank, b.rank);
    for (Eigen::Index c = 0; c < s[1]; ++c) {
      EXPECT_EQ(a.x[c], b.x[c]) << names[static_cast<std::size_t>(c)];
      EXPECT_EQ(a.fitted[c], b.fitted[c]) << names[static_cast<std::size_t>(c)];
      if (std::isnan(a.u[c]))
        EXPECT_TRUE(std::isnan(b.u[c])) << names[static_cast<std::size_t>(c)];
      else
        EXPECT_NEAR(a.u[c], b.u[c], 1e-12 * a.u[c]) << names[static_cast<std::size_t>(c)];
    }
    EXPECT_LE((a.residual - b.residual).cwiseAbs().maxCoeff(), 1e-12 * a.residual.cwiseAbs().maxCoeff());
  }
  // Blocks of different heights are refused, not read past their end.
  const Problem p = random_problem(50, 2, 3);
  const Eigen::MatrixXd shorter = p.a.topRows(49);
  const auto r = guideway::models::solve_lsq(guideway::models::ColumnBlocks{p.a, shorter}, p.y, p.w,
                                             {"a", "b", "c", "d"});
  EXPECT_FALSE(r.ok);
}

// solve_lsq scans J for NaN and infinity only when the triangle is not finite: a non-finite value
// anywhere must still be refused, wherever it sits (first or last row, a padded last chunk, a row of
// zero weight, a column that is otherwise zero, behind a zero first column).
TEST(LsqTriangleTest, NonFiniteJacobianIsRefusedWherever) {
  const double bad_values[] = {std::nan(""), std::numeric_limits<double>::infinity(),
                               -std::numeric_limits<double>::infinity()};
  const Eigen::Index n = 1001, m = 6;
  const std::vector<std::string> names = {"a", "b", "c", "d", "e", "f"};
  const Eigen::Index cells[][2] = {{0, 0}, {n - 1, m - 1}, {n - 1, 0}, {500, 3}, {2, 4}, {700, 2}, {10, 1}};
  for (const double bad : bad_values) {
    for (const auto& cell : cells) {
      Problem p = random_problem(n, m, 9);
      p.a.col(2).setZero();  // cell (700, 2): the only non-zero of its column
      p.a.col(0).setZero();  // the first reflector is the identity
      p.a(0, 0) = cell[0] == 0 && cell[1] == 0 ? 0.0 : 1.0;
      p.a(cell[0], cell[1]) = bad;  // row 2 has weight 0
      const auto r = guideway::models::solve_lsq(p.a, p.y, p.w, names);
      EXPECT_FALSE(r.ok) << bad << " at (" << cell[0] << ", " << cell[1] << ")";
      EXPECT_NE(r.message.find("non-finite"), std::string::npos) << r.message;
    }
  }
  // Finite data of the same shapes are solved.
  const Problem p = random_problem(n, m, 9);
  EXPECT_TRUE(guideway::models::solve_lsq(p.a, p.y, p.w, names).ok);
}

}  // namespace
