#pragma once
// The triangle R of a Householder QR of a tall weighted least-squares problem, computed in one pass
// over the data: rows are weighted and reduced chunk by chunk into a running (m+1) x (m+1) triangle
// (a sequential tall-skinny QR), so the chunk being reduced stays in the L1 cache and no weighted
// copy of the n x m matrix is ever made. Q is never formed. Pure function; thread safe.

#include <vector>

#include <Eigen/Core>

namespace guideway::models {

// R, upper triangular (m+1) x (m+1), with [diag(sw) A, diag(sw) y] = Q [R; 0] for A n x m and Q
// orthogonal: R^T R = [A y]^T diag(sw)^2 [A y]. R(0:m, m) is then Q^T (sw y) and |R(m, m)| the norm of
// the weighted residual of the least-squares solution. Row signs are those of LAPACK's dgeqrf
// (the diagonal may be negative). Sizes are the caller's to check (sw.size() == y.size() == A.rows()).
// The vector width of the kernel: `automatic` takes AVX2 where the CPU has it. Every kernel gives
// the same bits (the sums are formed in one fixed order, without FMA); the choice is for tests.
enum class TriangleKernel { automatic, portable, avx2 };
Eigen::MatrixXd weighted_triangle(const Eigen::Ref<const Eigen::MatrixXd>& a, const Eigen::VectorXd& y, const Eigen::VectorXd& sw,
                                  TriangleKernel kernel = TriangleKernel::automatic);

// A matrix given as blocks of its columns side by side, each where its owner holds it: never copied into one
// (a design whose base a problem holds beside the few columns made for one fit). Every block has the same rows.
using ColumnBlocks = std::vector<Eigen::Ref<const Eigen::MatrixXd>>;
// The same of A = [blocks...]: the same bits as of A copied into one matrix.
Eigen::MatrixXd weighted_triangle(const ColumnBlocks& a, const Eigen::VectorXd& y, const Eigen::VectorXd& sw,
                                  TriangleKernel kernel = TriangleKernel::automatic);

// Whether TriangleKernel::avx2 runs here (x86-64 GCC build and an AVX2 CPU); asking for it elsewhere
// throws std::invalid_argument.
bool householder_avx2_available();

}  // namespace guideway::models
