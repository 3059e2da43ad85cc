#include "daemon/channel_denoiser.hpp"

#include <bit>
#include <cmath>
#include <stdexcept>

namespace guideway::daemon {

class ChannelDenoiser::Sink : public dsp::WaveletSink {
 public:
  explicit Sink(ChannelDenoiser& owner) : owner_(owner) {}
  void on_denoised(std::uint64_t first_sample, std::span<const double> values) override {
    const std::size_t mask = owner_.pending_capacity_ - 1;
    for (std::size_t i = 0; i < values.size(); ++i) owner_.denoised_[(first_sample + i) & mask] = values[i];
    owner_.denoised_count_ = first_sample + values.size();
  }

 private:
  ChannelDenoiser& owner_;
};

namespace {

dsp::StreamingOptions denoise_only(dsp::StreamingOptions options) {
  options.coefficients = false;
  options.components = false;
  options.denoise = true;
  return options;
}

}  // namespace

ChannelDenoiser::ChannelDenoiser(std::size_t channel, const dsp::Wavelet& wavelet,
                                 const dsp::StreamingOptions& options, std::size_t max_batch)
    : channel_(channel),
      max_batch_(max_batch),
      wavelet_(wavelet, denoise_only(options)),
      // Valid samples wait at most the latency; room beyond that absorbs unusable samples queued behind them.
      pending_capacity_(std::bit_ceil(wavelet_.latency() + 2 * max_batch + 4096)),
      pending_(pending_capacity_),
      pending_index_(pending_capacity_, -1),
      denoised_(pending_capacity_, 0.0) {
  if (channel >= max_sample_values) throw std::invalid_argument("channel index beyond the sample's values");
  if (max_batch == 0) throw std::invalid_argument("max_batch must be positive");
  scratch_.reserve(max_batch);
}

bool ChannelDenoiser::usable(const Sample& s) const noexcept {
  constexpr std::uint32_t unusable = sample_out_of_range | sample_no_signal;
  return channel_ < s.value_count && (s.flags & unusable) == 0 && std::isfinite(s.value[channel_]);
}

void ChannelDenoiser::process(std::span<const Sample> in, std::vector<Sample>& out) {
  if (in.size() > max_batch_) throw std::invalid_argument("batch larger than max_batch");
  if (pending_tail_ - pending_head_ + in.size() > pending_capacity_) flush_and_restart(out);
  const std::size_t mask = pending_capacity_ - 1;
  scratch_.clear();
  for (const Sample& s : in) {
    const std::size_t slot = pending_tail_++ & mask;
    pending_[slot] = s;
    if (usable(s)) {
      pending_index_[slot] = static_cast<std::int64_t>(pushed_count_++);
      scratch_.push_back(s.value[channel_]);
    } else {
      pending_index_[slot] = -1;
      passed_through_.fetch_add(1, std::memory_order_relaxed);
    }
  }
  Sink sink(*this);
  wavelet_.push(scratch_, sink);
  release(out);
}

void ChannelDenoiser::release(std::vector<Sample>& out) {
  const std::size_t mask = pending_capacity_ - 1;
  while (pending_head_ != pending_tail_) {
    const std::size_t slot = pending_head_ & mask;
    const std::int64_t index = pending_index_[slot];
    if (index >= 0) {
      if (static_cast<std::uint64_t>(index) >= denoised_count_) break;
      pending_[slot].value[channel_] = denoised_[static_cast<std::size_t>(index) & mask];
    }
    out.push_back(pending_[slot]);
    ++pending_head_;
  }
}

void ChannelDenoiser::flush_and_restart(std::vector<Sample>& out) {
  Sink sink(*this);
  wavelet_.flush(sink);
  release(out);
  wavelet_.reset();
  pushed_count_ = 0;
  denoised_count_ = 0;
  restarts_.fetch_add(1, std::memory_order_relaxed);
}

}  // namespace guideway::daemon
