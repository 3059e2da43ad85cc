// A device's [[processing]] steps applied in order to its stream (processing_chain.hpp).
#include "daemon/processing_chain.hpp"

#include <algorithm>

namespace guideway::daemon {

ProcessingChain::ProcessingChain(const std::vector<DenoiserSpec>& steps, std::size_t max_batch) : max_batch_(max_batch) {
  std::size_t bound = 0;
  for (const auto& spec : steps) {
    steps_.push_back(std::make_unique<ChannelDenoiser>(spec, max_batch));
    bound += steps_.back()->output_bound();
  }
  // A step can release its whole backlog at once (a restart): the later steps take it in max_batch pieces.
  for (auto& b : buffers_) b.reserve(bound);
}

std::span<const Sample> ProcessingChain::run_from(std::size_t first_step, std::span<const Sample> in) {
  std::span<const Sample> current = in;
  std::size_t which = 0;
  for (std::size_t k = first_step; k < steps_.size(); ++k) {
    std::vector<Sample>& out = buffers_[which];
    out.clear();
    for (std::size_t offset = 0; offset < current.size(); offset += max_batch_) {
      steps_[k]->process(current.subspan(offset, std::min(max_batch_, current.size() - offset)), out);
    }
    current = out;
    which ^= 1;
  }
  return current;
}

std::span<const Sample> ProcessingChain::process(std::span<const Sample> raw) { return run_from(0, raw); }

std::span<const Sample> ProcessingChain::flush() {
  flushed_.clear();
  for (std::size_t k = 0; k < steps_.size(); ++k) {
    tail_.clear();
    steps_[k]->flush(tail_);
    const auto out = run_from(k + 1, tail_);
    flushed_.insert(flushed_.end(), out.begin(), out.end());
  }
  return flushed_;
}

nlohmann::json ProcessingChain::to_json() const {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& s : steps_) j.push_back(s->spec().to_json());
  return j;
}

}  // namespace guideway::daemon
