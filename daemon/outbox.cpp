// The pipeline's messages handed to the event loop (outbox.hpp): a bounded list under a mutex and an eventfd.
#include "daemon/outbox.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <system_error>

namespace guideway::daemon {

Outbox::Outbox(std::size_t max_messages)
    : event_fd_(eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)), max_messages_(max_messages) {
  if (event_fd_ < 0) throw std::system_error(errno, std::generic_category(), "eventfd");
}

Outbox::~Outbox() { close(event_fd_); }

void Outbox::post(Message message) {
  {
    std::lock_guard lock(mutex_);
    if (queue_.size() >= max_messages_) {
      auto oldest_sample = std::find_if(queue_.begin(), queue_.end(),
                                        [](const Message& m) { return m.cls == results::MessageClass::sample; });
      if (oldest_sample != queue_.end()) {
        queue_.erase(oldest_sample);
      } else if (message.cls == results::MessageClass::sample) {
        ++dropped_;
        return;
      }
      ++dropped_;
    }
    queue_.push_back(std::move(message));
  }
  const std::uint64_t one = 1;
  [[maybe_unused]] auto ignored = write(event_fd_, &one, sizeof(one));
}

std::vector<Message> Outbox::take() {
  std::uint64_t count = 0;
  [[maybe_unused]] auto ignored = read(event_fd_, &count, sizeof(count));
  std::lock_guard lock(mutex_);
  std::vector<Message> out(std::make_move_iterator(queue_.begin()), std::make_move_iterator(queue_.end()));
  queue_.clear();
  return out;
}

std::uint64_t Outbox::dropped() const {
  std::lock_guard lock(mutex_);
  return dropped_;
}

}  // namespace guideway::daemon
