// The daemon's epoll loop (event_loop.hpp): descriptors with callbacks, run until stop().
#include "daemon/event_loop.hpp"

#include <unistd.h>

#include <array>
#include <cerrno>
#include <memory>
#include <system_error>

namespace guideway::daemon {

EventLoop::EventLoop() : epoll_fd_(epoll_create1(EPOLL_CLOEXEC)) {
  if (epoll_fd_ < 0) throw std::system_error(errno, std::generic_category(), "epoll_create1");
}

EventLoop::~EventLoop() { close(epoll_fd_); }

void EventLoop::add(int fd, std::uint32_t events, Callback callback) {
  epoll_event ev{};
  ev.events = events;
  ev.data.fd = fd;
  if (epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &ev) != 0) {
    throw std::system_error(errno, std::generic_category(), "epoll_ctl(ADD)");
  }
  callbacks_[fd] = std::make_shared<Callback>(std::move(callback));
}

void EventLoop::modify(int fd, std::uint32_t events) {
  epoll_event ev{};
  ev.events = events;
  ev.data.fd = fd;
  if (epoll_ctl(epoll_fd_, EPOLL_CTL_MOD, fd, &ev) != 0) {
    throw std::system_error(errno, std::generic_category(), "epoll_ctl(MOD)");
  }
}

void EventLoop::remove(int fd) {
  epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
  callbacks_.erase(fd);
}

void EventLoop::run(int timeout_ms, const std::function<void()>& idle) {
  running_ = true;
  std::array<epoll_event, 64> events{};
  while (running_) {
    const int n = epoll_wait(epoll_fd_, events.data(), static_cast<int>(events.size()), timeout_ms);
    if (n < 0 && errno != EINTR) throw std::system_error(errno, std::generic_category(), "epoll_wait");
    for (int i = 0; i < n && running_; ++i) {
      auto it = callbacks_.find(events[static_cast<std::size_t>(i)].data.fd);
      if (it == callbacks_.end()) continue;  // removed by an earlier callback in this batch
      std::shared_ptr<Callback> keep = it->second;  // survives remove() from inside the callback
      (*keep)(events[static_cast<std::size_t>(i)].events);
    }
    if (idle) idle();
  }
}

}  // namespace guideway::daemon
