// The triangle R of a Householder QR built in one pass over a tall weighted problem (householder_triangle.hpp), chunk
// by chunk.
#include "models/common/householder_triangle.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace guideway::models {

namespace {

// Bytes of one chunk of weighted rows: reduced against the triangle while it sits in the L1 cache.
constexpr Eigen::Index chunk_bytes = 16 * 1024;

// The kernel once for SSE2 (every x86-64; the portable vector extension elsewhere) and, on x86-64
// with GCC, once more for AVX2 behind a run-time check. The AVX2 copy lives in its own namespace with
// internal linkage and #pragma GCC target applies only to the functions defined between push and
// pop, so no AVX2 code can be shared with (or chosen by the linker for) any other function; the
// kernel spells out its sums, so both copies give the same bits.
namespace portable {
using V = double __attribute__((vector_size(16)));
constexpr int lanes = 2;
#include "models/common/householder_kernel.inc"
}  // namespace portable

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define GUIDEWAY_HOUSEHOLDER_AVX2 1
#pragma GCC push_options
#pragma GCC target("avx2")
namespace avx2 {
using V = double __attribute__((vector_size(32)));
constexpr int lanes = 4;
#include "models/common/householder_kernel.inc"
}  // namespace avx2
#pragma GCC pop_options
#endif

bool avx2_usable() {
#ifdef GUIDEWAY_HOUSEHOLDER_AVX2
  static const bool usable = [] {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return usable;
#else
  return false;
#endif
}

}  // namespace

bool householder_avx2_available() { return avx2_usable(); }

Eigen::MatrixXd weighted_triangle(const Eigen::Ref<const Eigen::MatrixXd>& a, const Eigen::VectorXd& y, const Eigen::VectorXd& sw,
                                  TriangleKernel kernel) {
  return weighted_triangle(ColumnBlocks{a}, y, sw, kernel);
}

Eigen::MatrixXd weighted_triangle(const ColumnBlocks& a, const Eigen::VectorXd& y, const Eigen::VectorXd& sw,
                                  TriangleKernel kernel) {
  if (kernel == TriangleKernel::avx2 && !avx2_usable())
    throw std::invalid_argument("weighted_triangle: the AVX2 kernel is not available on this CPU");
  const bool use_avx2 = kernel == TriangleKernel::avx2 || (kernel == TriangleKernel::automatic && avx2_usable());
  const Eigen::Index n = y.size();
  Eigen::Index m = 0;
  for (const auto& b : a) m += b.cols();
  const Eigen::Index w = m + 1;
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(w, w);
  const Eigen::Index chunk = std::max<Eigen::Index>(8, chunk_bytes / (Eigen::Index{sizeof(double)} * w)) / 4 * 4;
  Eigen::MatrixXd buf(std::min(chunk, (n + 3) / 4 * 4), w);
  for (Eigen::Index i0 = 0; i0 < n; i0 += chunk) {
    const Eigen::Index used = std::min(chunk, n - i0);
    const Eigen::Index rows = (used + 3) / 4 * 4;  // zero rows pad the last chunk to a multiple of 4
    double* c = buf.data();
    const double* s = sw.data() + i0;
    double* dst = c;
    for (const auto& b : a)
      for (Eigen::Index j = 0; j < b.cols(); ++j, dst += rows) {
        const double* src = b.data() + j * b.outerStride() + i0;
        for (Eigen::Index i = 0; i < used; ++i) dst[i] = src[i] * s[i];
        for (Eigen::Index i = used; i < rows; ++i) dst[i] = 0.0;
      }
    const double* yi = y.data() + i0;
    for (Eigen::Index i = 0; i < used; ++i) dst[i] = yi[i] * s[i];
    for (Eigen::Index i = used; i < rows; ++i) dst[i] = 0.0;
    if (use_avx2) {
#ifdef GUIDEWAY_HOUSEHOLDER_AVX2
      avx2::reduce(r.data(), w, c, rows);
#endif
    } else {
      portable::reduce(r.data(), w, c, rows);
    }
  }
  return r;
}

}  // namespace guideway::models
