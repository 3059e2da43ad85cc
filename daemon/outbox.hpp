#pragma once
// Messages from the pipeline thread to the event loop, which fans them out to watching clients.
// Thread safe: post() from any thread; take() and fd() on the loop thread. Bounded: when the loop
// falls behind, the oldest SAMPLE messages go first and are counted; other classes are kept.

#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

#include "daemon/messages.hpp"

namespace guideway::daemon {

class Outbox {
 public:
  explicit Outbox(std::size_t max_messages = 65536);
  ~Outbox();
  Outbox(const Outbox&) = delete;
  Outbox& operator=(const Outbox&) = delete;

  void post(Message message);
  std::vector<Message> take();
  [[nodiscard]] int fd() const noexcept { return event_fd_; }  // readable when messages are waiting
  [[nodiscard]] std::uint64_t dropped() const;

 private:
  int event_fd_;
  std::size_t max_messages_;
  mutable std::mutex mutex_;
  std::deque<Message> queue_;
  std::uint64_t dropped_ = 0;
};

}  // namespace guideway::daemon
