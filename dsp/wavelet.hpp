#pragma once
// Discrete wavelet transforms, compatible with PyWavelets 1.1.1: same filter banks, signal-extension modes,
// coefficient lengths, band order and values (to rounding; bit-identical away from the signal edges).
// See docs/dsp.md. All functions throw std::invalid_argument with a message saying what is wrong.

#include <cstddef>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "dsp/wavelet_filters_data.hpp"

namespace guideway::dsp {

// An orthogonal wavelet filter bank: db1..db20 (alias haar = db1), sym2..sym20, coif1..coif5.
// Immutable view of static tables: cheap to copy, thread safe.
class Wavelet {
 public:
  explicit Wavelet(std::string_view name);  // throws std::invalid_argument for an unknown name
  [[nodiscard]] static std::vector<std::string> names();

  [[nodiscard]] std::string_view name() const { return data_->name; }
  [[nodiscard]] std::size_t filter_length() const { return data_->length; }
  [[nodiscard]] std::span<const double> dec_lo() const { return {data_->dec_lo, data_->length}; }
  [[nodiscard]] std::span<const double> dec_hi() const { return {data_->dec_hi, data_->length}; }
  [[nodiscard]] std::span<const double> rec_lo() const { return {data_->rec_lo, data_->length}; }
  [[nodiscard]] std::span<const double> rec_hi() const { return {data_->rec_hi, data_->length}; }

 private:
  const detail::FilterBankData* data_;
};

// Signal extension at the edges, with PyWavelets' semantics. `periodization` gives ceil(N/2) coefficients
// (an odd signal is first padded with its last sample); the others give floor((N + F - 1) / 2).
// `reflect` of a single sample behaves as `constant` (PyWavelets 1.1.1 does not terminate on that input).
enum class Mode { zero, constant, symmetric, periodic, reflect, periodization };

[[nodiscard]] Mode parse_mode(std::string_view name);  // throws std::invalid_argument
[[nodiscard]] std::string_view mode_name(Mode mode);
[[nodiscard]] std::vector<std::string> mode_names();

// Coefficients per band of one dwt level (pywt.dwt_coeff_len).
[[nodiscard]] std::size_t dwt_coeff_len(std::size_t signal_length, std::size_t filter_length, Mode mode);
// Deepest level with at least one coefficient free of boundary effects (pywt.dwt_max_level).
[[nodiscard]] int dwt_max_level(std::size_t signal_length, std::size_t filter_length);
// Length of idwt's output for `coeff_length` coefficients per band (2n - F + 2, or 2n for periodization).
[[nodiscard]] std::size_t idwt_len(std::size_t coeff_length, std::size_t filter_length, Mode mode);

struct DwtBands {
  std::vector<double> approx;
  std::vector<double> detail;
};

// One level: pywt.dwt(x, wavelet, mode).
[[nodiscard]] DwtBands dwt(std::span<const double> x, const Wavelet& wavelet, Mode mode);
// One level inverse: pywt.idwt(a, d, wavelet, mode); a and d of equal length.
[[nodiscard]] std::vector<double> idwt(std::span<const double> approx, std::span<const double> detail,
                                       const Wavelet& wavelet, Mode mode);

// Bands in PyWavelets' order: [cA_J, cD_J, cD_J-1, ..., cD_1].
using Coefficients = std::vector<std::vector<double>>;

// pywt.wavedec. level < 0 means dwt_max_level; a level above the maximum is allowed (as in PyWavelets, where
// it only warns): every coefficient then feels the boundary.
[[nodiscard]] Coefficients wavedec(std::span<const double> x, const Wavelet& wavelet, Mode mode, int level = -1);
// pywt.waverec: for an odd-length signal the result has one sample more than the signal, as in PyWavelets.
[[nodiscard]] std::vector<double> waverec(const Coefficients& coeffs, const Wavelet& wavelet, Mode mode);
// Multiresolution analysis: the signal-domain component of every band, [A_J, D_J, ..., D_1] (PyWavelets'
// band order), each of the signal's length; component b equals waverec of the coefficients with every band but
// b set to zero (first N samples), and the components sum to the signal (to rounding).
[[nodiscard]] std::vector<std::vector<double>> mra(std::span<const double> x, const Wavelet& wavelet, Mode mode,
                                                   int level = -1);

// Repeated transforms of signals of one length, without allocation: all buffers are sized at construction.
// Coefficients are "packed": the bands in PyWavelets' order, concatenated (band_offset/band_length).
// Not thread safe (holds scratch buffers): one plan per thread.
class WaveletPlan {
 public:
  WaveletPlan(const Wavelet& wavelet, Mode mode, std::size_t signal_length, int level = -1);

  [[nodiscard]] const Wavelet& wavelet() const { return wavelet_; }
  [[nodiscard]] Mode mode() const { return mode_; }
  [[nodiscard]] int level() const { return level_; }
  [[nodiscard]] std::size_t signal_length() const { return n_[0]; }
  [[nodiscard]] std::size_t band_count() const { return static_cast<std::size_t>(level_) + 1; }
  [[nodiscard]] std::size_t band_length(std::size_t band) const;  // band 0 = cA_J, band b >= 1 = cD_(J+1-b)
  [[nodiscard]] std::size_t band_offset(std::size_t band) const;
  [[nodiscard]] std::size_t coeff_count() const { return offset_.back(); }
  [[nodiscard]] std::size_t reconstruction_length() const { return rec_len_; }  // N or N+1, as pywt.waverec

  // x.size() == signal_length(), packed.size() >= coeff_count().
  void decompose(std::span<const double> x, std::span<double> packed);
  // out.size() >= reconstruction_length().
  void reconstruct(std::span<const double> packed, std::span<double> out);
  // The signal-domain component of one band into out (out.size() >= signal_length()).
  void component(std::span<const double> packed, std::size_t band, std::span<double> out);
  // All components, band-major: out[b * N + t], out.size() >= band_count() * signal_length().
  void components(std::span<const double> packed, std::span<double> out);

 private:
  void check_packed(std::span<const double> packed) const;

  Wavelet wavelet_;
  Mode mode_;
  int level_;
  std::vector<std::size_t> n_;       // n_[l] = coefficients per band at level l (n_[0] = signal length)
  std::vector<std::size_t> offset_;  // band offsets in the packed layout, plus the total
  std::size_t rec_len_ = 0;
  std::vector<double> scratch_a_;
  std::vector<double> scratch_b_;
};

}  // namespace guideway::dsp
