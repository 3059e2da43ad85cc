#pragma once
// Online multilevel wavelet decomposition, multiresolution components and denoising of a sample stream.
//
// The stream is a per-level cascade of analysis filters whose history starts as zeros, i.e. the stream is
// PyWavelets' `zero` mode: after flush() every coefficient and every component sample equals the batch
// result in Mode::zero bit for bit (same kernels, same summation order), for any chunking of the input.
// Against the other batch modes only the coefficients influenced by the signal's edges differ (the first and
// last few per level, see docs/dsp.md); interior coefficients are bit-identical.
//
// Timing (F = filter length, J = levels, n = samples pushed so far):
// - coefficient o of level j (band cD_j or, at j = J, cA_J) is delivered by the push that brings sample
//   2^j (o + 1) - 1: no delay beyond the filter's own causal support;
// - components (MRA) and the denoised signal have a fixed latency L = (F - 1)(2^J - 1) samples: after n samples,
//   exactly max(0, n - L) output samples have been delivered (the theoretical minimum: the deepest band's
//   synthesis needs exactly that many later samples for some output phases). flush() delivers the rest, up to n.
// Memory is allocated at construction only (push/flush/reset never allocate; they may throw only on misuse).
// Single-threaded: one object per channel, used by one thread.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "dsp/denoise.hpp"
#include "dsp/wavelet.hpp"

namespace guideway::dsp {

// Receives the outputs of a StreamingWavelet, in order. Bands and components use PyWavelets' order:
// band 0 = cA_J / A_J, band b >= 1 = cD_(J+1-b) / D_(J+1-b). Spans are valid during the call only.
class WaveletSink {
 public:
  virtual ~WaveletSink() = default;
  // Coefficients [first_index, first_index + values.size()) of one band.
  virtual void on_coefficients(std::size_t /*band*/, std::uint64_t /*first_index*/,
                               std::span<const double> /*values*/) {}
  // Signal-domain components for samples [first_sample, first_sample + count): components[b][i].
  virtual void on_components(std::uint64_t /*first_sample*/, std::size_t /*count*/,
                             std::span<const double* const> /*components*/) {}
  // Denoised signal for samples [first_sample, first_sample + values.size()).
  virtual void on_denoised(std::uint64_t /*first_sample*/, std::span<const double> /*values*/) {}
};

struct StreamingDenoiseOptions {
  ThresholdRule rule = ThresholdRule::soft;
  bool level_dependent = false;     // sigma per level from that level's recent details
  std::optional<double> sigma;      // known noise level (no estimation)
  std::optional<double> threshold;  // fixed lambda for every detail band (overrides sigma)
  // Noise estimate: median(|d|)/0.6745 over the last `window` detail coefficients, refreshed every window/4
  // coefficients (and at 16, 32, 64, ... while the window fills; before 16 coefficients nothing is thresholded).
  std::size_t window = 1024;
  // N of lambda = sigma sqrt(2 ln N); 0 = 2 * window.
  std::size_t threshold_length = 0;
};

struct StreamingOptions {
  int levels = 5;            // 1..16
  bool coefficients = true;  // deliver on_coefficients
  bool components = false;   // compute and deliver on_components (MRA)
  bool denoise = false;      // compute and deliver on_denoised
  StreamingDenoiseOptions denoise_options;
  std::size_t block = 1024;  // internal processing block (samples); bounds the buffers, not the push size
};

// See the file comment. Usage: construct per channel, push() chunks of any size, flush() at the end of a
// session, reset() before the next one.
class StreamingWavelet {
 public:
  StreamingWavelet(const Wavelet& wavelet, const StreamingOptions& options);
  ~StreamingWavelet();
  StreamingWavelet(StreamingWavelet&&) noexcept;
  StreamingWavelet& operator=(StreamingWavelet&&) noexcept;

  [[nodiscard]] const Wavelet& wavelet() const;
  [[nodiscard]] int levels() const;
  // L = (F - 1)(2^J - 1): latency of components and denoised samples.
  [[nodiscard]] std::size_t latency() const;
  [[nodiscard]] static std::size_t latency_for(std::size_t filter_length, int levels);
  [[nodiscard]] std::uint64_t samples_pushed() const;
  [[nodiscard]] bool finished() const;  // flush() was called

  // Any number of samples (0 allowed). Throws std::logic_error after flush() until reset().
  void push(std::span<const double> x, WaveletSink& sink);
  // Ends the stream: the remaining coefficients (PyWavelets' zero-mode right edge: all bands then have
  // dwt_coeff_len lengths for the samples pushed), and components/denoised samples up to samples_pushed().
  void flush(WaveletSink& sink);
  // Back to the initial state (zero history), keeping the buffers.
  void reset();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace guideway::dsp
