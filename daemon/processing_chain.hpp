#pragma once
// The [[processing]] steps of one device, applied in order to its sample stream. The pipeline keeps
// one continuous chain per device for the live SAMPLE stream; every session gets a fresh chain of the
// same steps at its start, so that replaying its raw recording repeats exactly what it saw.
// Single-threaded; buffers are reserved at construction, process() does not allocate.

#include <array>
#include <memory>
#include <span>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/channel_denoiser.hpp"

namespace guideway::daemon {

class ProcessingChain {
 public:
  ProcessingChain() = default;
  ProcessingChain(const std::vector<DenoiserSpec>& steps, std::size_t max_batch);

  [[nodiscard]] bool empty() const noexcept { return steps_.empty(); }
  // The processed samples that are ready after `raw` (raw itself for an empty chain); valid until the
  // next call.
  std::span<const Sample> process(std::span<const Sample> raw);
  // Ends the stream: every sample still held, in order; the chain then starts afresh.
  std::span<const Sample> flush();

  [[nodiscard]] const std::vector<std::unique_ptr<ChannelDenoiser>>& steps() const noexcept { return steps_; }
  // The steps as recorded in a raw recording's `processing` header (a JSON array).
  [[nodiscard]] nlohmann::json to_json() const;

 private:
  std::span<const Sample> run_from(std::size_t first_step, std::span<const Sample> in);

  std::size_t max_batch_ = 1;
  std::vector<std::unique_ptr<ChannelDenoiser>> steps_;
  std::array<std::vector<Sample>, 2> buffers_;  // ping-pong between steps
  std::vector<Sample> tail_;                    // flush(): one step's tail
  std::vector<Sample> flushed_;                 // flush(): the result
};

}  // namespace guideway::daemon
