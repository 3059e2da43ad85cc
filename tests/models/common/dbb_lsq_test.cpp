// models/common least squares against numpy/scipy (/usr/bin/python3, tests/models/common/dbb_lsq_oracle.py):
// estimates, standard uncertainties, condition number, rank; tolerances stated per check.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>

#include "models/common/least_squares.hpp"
#include "models/dbb/identify.hpp"
#include "test_support.hpp"

namespace {

using guideway::models::LsqResult;
using guideway::models::solve_lsq;

struct Oracle {
  std::size_t rank = 0;
  double rms = 0, cond = 0;
  std::vector<double> x, u;
};

bool have_numpy() { return std::system("/usr/bin/python3 -c 'import numpy, scipy' >/dev/null 2>&1") == 0; }

Oracle run_oracle(const Eigen::MatrixXd& j, const Eigen::VectorXd& y, const Eigen::VectorXd& w) {
  guideway::test::TempDir dir;
  {
    std::ofstream in(dir.file("in.csv"));
    in.precision(17);
    for (Eigen::Index i = 0; i < j.rows(); ++i) {
      in << w[i] << "," << y[i];
      for (Eigen::Index c = 0; c < j.cols(); ++c) in << "," << j(i, c);
      in << "\n";
    }
  }
  const std::string cmd = "/usr/bin/python3 " GUIDEWAY_SOURCE_DIR "/tests/models/common/dbb_lsq_oracle.py " +
                          dir.file("in.csv") + " " + dir.file("out.txt");
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  Oracle o;
  std::ifstream out(dir.file("out.txt"));
  std::string key;
  out >> key >> o.rank >> key >> o.rms >> key >> o.cond;
  double x, u;
  while (out >> x >> u) {
    o.x.push_back(x);
    o.u.push_back(u);
  }
  return o;
}

std::vector<std::string> names(Eigen::Index m) {
  std::vector<std::string> n;
  for (Eigen::Index i = 0; i < m; ++i) n.push_back("p" + std::to_string(i));
  return n;
}

TEST(DbbLsqTest, RandomWeightedProblemMatchesNumpy) {
  if (!have_numpy()) GTEST_SKIP() << "/usr/bin/python3 with numpy and scipy is not available";
  std::mt19937_64 rng(7);
  std::normal_distribution<double> nd;
  const Eigen::Index n = 300, m = 7;
  Eigen::MatrixXd j(n, m);
  Eigen::VectorXd y(n), w(n), truth(m);
  for (Eigen::Index c = 0; c < m; ++c) truth[c] = nd(rng) * std::pow(10.0, static_cast<double>(c) - 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index c = 0; c < m; ++c)
      j(i, c) = nd(rng) * std::pow(10.0, 3.0 - static_cast<double>(c));  // badly scaled columns
    w[i] = 0.5 + std::abs(nd(rng));
    y[i] = j.row(i).dot(truth) + 0.01 * nd(rng);
  }
  const LsqResult r = solve_lsq(j, y, w, names(m));
  ASSERT_TRUE(r.ok) << r.message;
  const Oracle o = run_oracle(j, y, w);
  ASSERT_EQ(o.x.size(), static_cast<std::size_t>(m));
  EXPECT_EQ(o.rank, r.rank);
  for (Eigen::Index c = 0; c < m; ++c) {
    EXPECT_NEAR(r.x[c], o.x[static_cast<std::size_t>(c)],
                1e-9 * std::abs(o.x[static_cast<std::size_t>(c)]) + 1e-15);                          // relative 1e-9
    EXPECT_NEAR(r.u[c], o.u[static_cast<std::size_t>(c)], 1e-7 * o.u[static_cast<std::size_t>(c)]);  // relative 1e-7
  }
  EXPECT_NEAR(r.rms, o.rms, 1e-10 * o.rms);
  EXPECT_NEAR(r.condition_number, o.cond, 1e-8 * o.cond);
}

// The Lai design matrix of the four-pattern case (full rank) and of Lai's three patterns (rank
// deficient): same estimates/uncertainties, same rank, same residual.
Eigen::MatrixXd lai_design(const std::vector<std::array<double, 3>>& patterns, std::size_t per, Eigen::VectorXd& y,
                           Eigen::VectorXd& w) {
  const auto names = guideway::models::dbb::lai3_parameter_names();
  const auto m = static_cast<Eigen::Index>(names.size());
  const auto n = static_cast<Eigen::Index>(patterns.size() * per);
  Eigen::MatrixXd j(n, m);
  y.resize(n);
  w = Eigen::VectorXd::Ones(n);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> nd;
  Eigen::Index row = 0;
  for (const auto& [r, h, dir] : patterns) {
    for (std::size_t i = 0; i < per; ++i, ++row) {
      const double z = dir * 2 * M_PI * static_cast<double>(i) / static_cast<double>(per);
      const auto b = guideway::models::dbb::lai3_characteristics(r, h, static_cast<int>(dir), 1.0 / 60, z);
      for (Eigen::Index c = 0; c < m; ++c) j(row, c) = b[static_cast<std::size_t>(c)] * 1e6;
      y[row] = 3 * std::cos(z) + 1e-2 * std::sin(3 * z) + 0.1 * nd(rng);
    }
  }
  return j;
}

TEST(DbbLsqTest, LaiDesignMatricesMatchNumpy) {
  if (!have_numpy()) GTEST_SKIP() << "/usr/bin/python3 with numpy and scipy is not available";
  Eigen::VectorXd y, w;
  const auto n = guideway::models::dbb::lai3_parameter_names();
  {
    const Eigen::MatrixXd j =
        lai_design({{0.095, 0.031225, 1}, {0.095, 0.031225, -1}, {0.1, 0, 1}, {0.07, 0.031225, 1}}, 720, y, w);
    const LsqResult r = solve_lsq(j, y, w, n);
    const Oracle o = run_oracle(j, y, w);
    ASSERT_EQ(r.rank, o.rank);
    ASSERT_EQ(o.x.size(), n.size());
    for (std::size_t c = 0; c < n.size(); ++c) {
      EXPECT_NEAR(r.x[static_cast<Eigen::Index>(c)], o.x[c], 1e-6 * o.u[c]) << n[c];  // within 1e-6 u
      EXPECT_NEAR(r.u[static_cast<Eigen::Index>(c)], o.u[c], 1e-6 * o.u[c]) << n[c];
    }
  }
  {
    const Eigen::MatrixXd j = lai_design({{0.095, 0.031225, 1}, {0.095, 0.031225, -1}, {0.1, 0, 1}}, 720, y, w);
    const LsqResult r = solve_lsq(j, y, w, n);
    const Oracle o = run_oracle(j, y, w);
    EXPECT_EQ(r.rank, o.rank);  // 20 parameters, rank 16
    EXPECT_EQ(r.unidentifiable.size(), 7u);
    EXPECT_NEAR(r.rms, o.rms, 1e-9 * o.rms);  // the projection is unique even when the parameters are not
  }
}

TEST(DbbLsqTest, RefusesDegenerateInput) {
  Eigen::MatrixXd j(3, 3);
  j.setIdentity();
  Eigen::VectorXd y = Eigen::VectorXd::Ones(3);
  auto r = solve_lsq(j, y, {}, names(3));
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("3 data points for 3 parameters"), std::string::npos);
  j.resize(5, 2);
  j.setOnes();
  y = Eigen::VectorXd::Ones(5);
  y[2] = std::nan("");
  r = solve_lsq(j, y, {}, names(2));
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("non-finite"), std::string::npos);
  // Two identical columns: both named, a combination reported.
  y = Eigen::VectorXd::LinSpaced(5, 1, 5);
  j.col(0) = Eigen::VectorXd::LinSpaced(5, 0, 1);
  j.col(1) = 2 * j.col(0);
  r = solve_lsq(j, y, {}, {"a", "b"});
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.unidentifiable, (std::vector<std::string>{"a", "b"}));
  ASSERT_EQ(r.combinations.size(), 1u);
  EXPECT_EQ(r.combinations[0].expression, "a + 2*b");
}

}  // namespace
