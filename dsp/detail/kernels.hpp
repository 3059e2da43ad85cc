#pragma once
// Inner loops of the wavelet transforms, shared by the batch and the streaming paths so that both sum the
// taps of every output in the same order (j ascending, as PyWavelets does) and give bit-identical results.
// Internal header: no argument checking.

#include <cstddef>

namespace guideway::dsp::detail {

// Analysis (filter + downsample by 2), both bands in one pass over the input:
//   a[o] = sum_{j=0}^{F-1} lo[j] * w[2o + F-1 - j],  d[o] likewise with hi,  o in [0, n).
// `w` points at the first sample of output 0's window; it must hold 2n + F - 2 samples.
using AnalysisFn = void (*)(const double* w, std::size_t n, const double* lo, const double* hi, double* a, double* d);

// Synthesis of one band (upsample by 2 + filter, "valid" part, PyWavelets' idwt order):
//   y[2m+e] = sum_{p=0}^{F/2-1} g[2p+e] * c[m + F/2-1 - p],  m in [0, n), e in {0, 1}.
// `c` must hold n + F/2 - 1 values; y receives 2n values.
using Synthesis1Fn = void (*)(const double* c, std::size_t n, const double* g, double* y);

// Synthesis of two bands: y = (approximation part) + (detail part), each summed as in Synthesis1Fn.
using Synthesis2Fn = void (*)(const double* a, const double* d, std::size_t n, const double* ga, const double* gd,
                              double* y);

struct Kernels {
  AnalysisFn analysis;
  Synthesis1Fn synthesis1;
  Synthesis2Fn synthesis2;
};

// Kernels specialised for an even filter length in [2, 40]; nullptr members for other lengths. The variant
// (AVX2 or baseline) is chosen once per process from the CPU; both give identical bits.
const Kernels& kernels_for(std::size_t filter_length);
// One variant explicitly (for the test that they agree): avx2 = false is the baseline build; with avx2 = true
// and a CPU without AVX2 the result is the baseline too.
const Kernels& kernels_variant(std::size_t filter_length, bool avx2);

}  // namespace guideway::dsp::detail
