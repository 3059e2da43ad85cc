// Online wavelet denoising of one channel (channel_denoiser.hpp), a pipeline processing step.
#include "daemon/channel_denoiser.hpp"

#include <algorithm>
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

nlohmann::json DenoiserSpec::to_json() const {
  const auto& d = options.denoise_options;
  return {{"step", "wavelet_denoise"},
          {"channel", channel_name},
          {"wavelet", wavelet},
          {"levels", options.levels},
          {"threshold", d.rule == dsp::ThresholdRule::soft ? "soft" : "hard"},
          {"level_dependent", d.level_dependent},
          {"noise_window", d.window}};
}

DenoiserSpec DenoiserSpec::from_json(const nlohmann::json& j, const std::vector<drivers::ChannelInfo>& channels) {
  try {
    DenoiserSpec spec;
    if (j.value("step", std::string("wavelet_denoise")) != "wavelet_denoise") {
      throw std::invalid_argument("unknown processing step \"" + j.value("step", std::string()) + "\"");
    }
    spec.channel_name = j.at("channel").get<std::string>();
    const auto it = std::find_if(channels.begin(), channels.end(),
                                 [&](const drivers::ChannelInfo& c) { return c.name == spec.channel_name; });
    if (it == channels.end()) throw std::invalid_argument("no channel \"" + spec.channel_name + "\"");
    spec.channel = static_cast<std::size_t>(it - channels.begin());
    spec.wavelet = j.at("wavelet").get<std::string>();
    (void)dsp::Wavelet(spec.wavelet);  // throws for an unknown name
    spec.options.levels = j.at("levels").get<int>();
    if (spec.options.levels < 1 || spec.options.levels > 12) throw std::invalid_argument("levels must be 1..12");
    spec.options.denoise_options.rule = dsp::parse_threshold_rule(j.at("threshold").get<std::string>());
    spec.options.denoise_options.level_dependent = j.at("level_dependent").get<bool>();
    spec.options.denoise_options.window = j.at("noise_window").get<std::size_t>();
    if (spec.options.denoise_options.window < 64) throw std::invalid_argument("noise_window must be >= 64");
    return spec;
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(std::string("processing step: ") + e.what());
  }
}

ChannelDenoiser::ChannelDenoiser(const DenoiserSpec& spec, std::size_t max_batch)
    : spec_(spec),
      channel_(spec.channel),
      max_batch_(max_batch),
      wavelet_(dsp::Wavelet(spec.wavelet), denoise_only(spec.options)),
      // Valid samples wait at most the latency; room beyond that absorbs unusable samples queued behind them.
      pending_capacity_(std::bit_ceil(wavelet_.latency() + 2 * max_batch + 4096)),
      pending_(pending_capacity_),
      pending_index_(pending_capacity_, -1),
      denoised_(pending_capacity_, 0.0) {
  if (channel_ >= max_sample_values) throw std::invalid_argument("channel index beyond the sample's values");
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

void ChannelDenoiser::flush(std::vector<Sample>& out) {
  flush_and_restart(out);
  restarts_.fetch_sub(1, std::memory_order_relaxed);  // an ordered end, not a restart
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
