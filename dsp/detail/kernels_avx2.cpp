// The kernels compiled for AVX2 (chosen at run time by kernels.cpp when the CPU has it).
#include <array>
#include <utility>

#define KERNEL_NS avx2
#include "dsp/detail/kernels_impl.hpp"

namespace guideway::dsp::detail {
const std::array<Kernels, 20>& avx2_kernel_table() {
  static const std::array<Kernels, 20> table = avx2::make_table(std::make_index_sequence<20>{});
  return table;
}
}  // namespace guideway::dsp::detail
