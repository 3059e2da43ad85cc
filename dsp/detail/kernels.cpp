// Filter-length-specialised inner loops (kernels_impl.hpp), baseline x86-64 build plus an AVX2 build chosen at
// run time. Both round identically (see kernels_impl.hpp), so the choice never changes a result.
#include "dsp/detail/kernels.hpp"

#include <array>
#include <utility>

#define KERNEL_NS generic
#include "dsp/detail/kernels_impl.hpp"

namespace guideway::dsp::detail {

const std::array<Kernels, 20>& avx2_kernel_table();

namespace {

constexpr std::size_t kMaxHalf = 20;  // filter lengths 2, 4, ..., 40
const Kernels kNone{nullptr, nullptr, nullptr};

const std::array<Kernels, kMaxHalf>& generic_table() {
  static const std::array<Kernels, kMaxHalf> t = generic::make_table(std::make_index_sequence<kMaxHalf>{});
  return t;
}

bool cpu_has_avx2() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

const std::array<Kernels, kMaxHalf>& table() {
  static const std::array<Kernels, kMaxHalf>* chosen = cpu_has_avx2() ? &avx2_kernel_table() : &generic_table();
  return *chosen;
}

}  // namespace

const Kernels& kernels_for(std::size_t filter_length) {
  if (filter_length < 2 || filter_length % 2 != 0 || filter_length / 2 > kMaxHalf) return kNone;
  return table()[filter_length / 2 - 1];
}

const Kernels& kernels_variant(std::size_t filter_length, bool avx2) {
  if (filter_length < 2 || filter_length % 2 != 0 || filter_length / 2 > kMaxHalf) return kNone;
  const auto& t = avx2 && cpu_has_avx2() ? avx2_kernel_table() : generic_table();
  return t[filter_length / 2 - 1];
}

}  // namespace guideway::dsp::detail
