#pragma once
// Online wavelet denoising of one channel of a device's sample stream (a pipeline processing step,
// configured by a [[processing]] table). Samples come out in input order with the channel's value
// replaced by its denoised value, delayed by the wavelet's fixed latency L = (F-1)(2^J-1) valid samples
// (dsp/streaming_wavelet.hpp). Samples whose value cannot be used (flagged out of range / no signal,
// NaN or infinite, or missing the channel) are not fed to the wavelet: they pass through unchanged, in
// their place in the stream. Memory is allocated at construction only.
// Single-threaded (the pipeline thread); the counters may be read from any thread.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/sample.hpp"
#include "drivers/driver.hpp"
#include "dsp/streaming_wavelet.hpp"

namespace guideway::daemon {

// What a [[processing]] step does, as recorded in a session's raw recording (`processing` header) so
// that a replay repeats it exactly.
struct DenoiserSpec {
  std::size_t channel = 0;  // index into the device's channels
  std::string channel_name;
  std::string wavelet = "db4";
  dsp::StreamingOptions options;  // levels and denoising options (coefficient/component outputs unused)

  [[nodiscard]] nlohmann::json to_json() const;
  // Throws std::invalid_argument naming the problem (unknown channel or wavelet, bad value).
  static DenoiserSpec from_json(const nlohmann::json& j, const std::vector<drivers::ChannelInfo>& channels);
};

class ChannelDenoiser {
 public:
  // max_batch: the largest span process() is given (the pipeline's pop_bulk size).
  ChannelDenoiser(const DenoiserSpec& spec, std::size_t max_batch);

  // Appends to `out` every sample that is ready, in order. `out` must have room reserved for
  // output_bound() more samples (the pipeline reserves it once), so this never allocates.
  void process(std::span<const Sample> in, std::vector<Sample>& out);
  // Ends the stream: appends every sample still held (the denoised tail, PyWavelets' zero-mode right
  // edge) and starts afresh. At most output_bound() samples.
  void flush(std::vector<Sample>& out);
  // Most samples one process() call can append.
  [[nodiscard]] std::size_t output_bound() const noexcept { return pending_capacity_ + max_batch_; }

  [[nodiscard]] std::size_t channel() const noexcept { return channel_; }
  [[nodiscard]] const DenoiserSpec& spec() const noexcept { return spec_; }
  [[nodiscard]] std::size_t latency_samples() const noexcept { return wavelet_.latency(); }
  [[nodiscard]] const dsp::Wavelet& wavelet() const { return wavelet_.wavelet(); }
  [[nodiscard]] int levels() const { return wavelet_.levels(); }
  // Samples passed through without denoising (unusable values).
  [[nodiscard]] std::uint64_t passed_through() const noexcept { return passed_through_.load(std::memory_order_relaxed); }
  // Times the stream was flushed and restarted because unusable samples piled up behind valid ones
  // waiting for the latency (e.g. a long loss of signal): each restart costs the filter's warm-up.
  [[nodiscard]] std::uint64_t restarts() const noexcept { return restarts_.load(std::memory_order_relaxed); }

 private:
  class Sink;
  [[nodiscard]] bool usable(const Sample& s) const noexcept;
  void release(std::vector<Sample>& out);
  void flush_and_restart(std::vector<Sample>& out);

  DenoiserSpec spec_;
  std::size_t channel_;
  std::size_t max_batch_;
  dsp::StreamingWavelet wavelet_;
  // Samples waiting for their denoised value: a ring of capacity pending_capacity_ (power of two).
  std::size_t pending_capacity_;
  std::vector<Sample> pending_;
  std::vector<std::int64_t> pending_index_;  // wavelet sample index, or -1 = pass through
  std::uint64_t pending_head_ = 0;           // next to release
  std::uint64_t pending_tail_ = 0;           // next free
  // Denoised values by wavelet sample index modulo the same capacity.
  std::vector<double> denoised_;
  std::uint64_t denoised_count_ = 0;  // wavelet outputs delivered so far
  std::uint64_t pushed_count_ = 0;    // valid samples pushed so far
  std::vector<double> scratch_;       // the valid values of one batch
  std::atomic<std::uint64_t> passed_through_{0};
  std::atomic<std::uint64_t> restarts_{0};
};

}  // namespace guideway::daemon
