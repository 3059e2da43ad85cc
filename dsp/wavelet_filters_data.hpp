#pragma once
// Static filter-bank tables generated from PyWavelets by dsp/tools/gen_filters.py (see wavelet_filters_data.cpp).

#include <cstddef>

namespace guideway::dsp::detail {

// One orthogonal filter bank; all four filters have `length` taps (PyWavelets' filter_bank order).
struct FilterBankData {
  const char* name;
  std::size_t length;
  const double* dec_lo;
  const double* dec_hi;
  const double* rec_lo;
  const double* rec_hi;
};

extern const FilterBankData kFilterBanks[];
extern const std::size_t kFilterBankCount;

}  // namespace guideway::dsp::detail
