#pragma once
// One level of the batch transforms with the edge handling of each mode (internal; used by wavelet.cpp and the
// streaming code). No argument checking beyond the filter length.

#include <cstddef>
#include <span>

#include "dsp/wavelet.hpp"

namespace guideway::dsp::detail {

// The signal extended beyond [0, N) by `mode` (for periodization: padded to even length, then periodic).
double extended_value(std::span<const double> x, std::ptrdiff_t k, Mode mode);

// One analysis level: a and d receive dwt_coeff_len(x.size(), F, mode) values each.
void analysis_level(std::span<const double> x, const Wavelet& w, Mode mode, double* a, double* d);

// One synthesis level from n coefficients per band: the first n_out samples of idwt (n_out <= idwt_len).
// cd == nullptr synthesises `ca` alone (with rec_hi if ca_is_detail, else rec_lo): the band's own contribution.
void synthesis_level(const double* ca, const double* cd, std::size_t n, const Wavelet& w, Mode mode, bool ca_is_detail,
                     double* out, std::size_t n_out);

}  // namespace guideway::dsp::detail
