#pragma once
// A minimal epoll loop: file descriptors with callbacks, run until stop(). Single-threaded: every
// method is called from the loop's thread, except wake() which is thread safe.

#include <sys/epoll.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <unordered_map>

namespace guideway::daemon {

class EventLoop {
 public:
  using Callback = std::function<void(std::uint32_t events)>;

  EventLoop();
  ~EventLoop();
  EventLoop(const EventLoop&) = delete;
  EventLoop& operator=(const EventLoop&) = delete;

  void add(int fd, std::uint32_t events, Callback callback);
  void modify(int fd, std::uint32_t events);
  void remove(int fd);  // safe to call from inside a callback, also for the fd being served
  // Runs callbacks until stop(); timeout_ms bounds each wait so `idle` runs at least that often.
  void run(int timeout_ms, const std::function<void()>& idle);
  void stop() noexcept { running_ = false; }

 private:
  int epoll_fd_;
  bool running_ = false;
  std::unordered_map<int, std::shared_ptr<Callback>> callbacks_;
};

}  // namespace guideway::daemon
