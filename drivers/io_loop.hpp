#pragma once
// One thread's epoll loop serving many devices: file descriptors with handlers, timers on
// CLOCK_MONOTONIC with nanosecond deadlines, and hooks run once per wake-up. Drivers written for it
// are non-blocking state machines (Driver::attach); guidewayd runs every such device and the
// pipeline on one IoLoop, so the devices share wake-ups instead of each paying its own
// (bench/README.md, "One I/O thread").
//
// A wake-up runs, in order: the handlers of ready descriptors, the timers that are due, the wake
// hooks (devices that read in batches look at their sockets here, whatever woke the loop), the
// settle hooks (a device whose rest ended with an empty read rests on while another device found
// data in this pass, else waits for its next byte), then the end hooks (the pipeline). A handler that leaves work for
// later (a device that floods its socket) calls again(): the next pass comes at once, after every other device was
// served. Thread safety: post(), call(), stop(), wakeups() from any thread; everything else on the loop's thread (or on
// any one thread before run() starts and after it returned).

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

namespace guideway::drivers {

class IoLoop {
 public:
  using FdHandler = std::function<void(std::uint32_t events)>;
  using Callback = std::function<void()>;
  using Id = std::uint64_t;
  static constexpr std::int64_t never = INT64_MAX;

  IoLoop();  // throws std::system_error (epoll, eventfd)
  ~IoLoop();
  IoLoop(const IoLoop&) = delete;
  IoLoop& operator=(const IoLoop&) = delete;

  // Serves on a thread of its own, named thread_name (at most 15 characters), until stop(); returns
  // once the loop runs. The thread's timer slack is 10 us, so sub-millisecond periods are kept.
  void start(const std::string& thread_name);
  // Or serves on the calling thread until stop().
  void run();
  // Ends the loop (what was posted still runs) and, when it has a thread of its own, joins it.
  void stop();
  // Runs fn on the loop's thread at its next pass.
  void post(Callback fn);
  // Runs fn on the loop's thread and returns when it has (what it throws is thrown here); at once when
  // called on that thread or while the loop does not run. Not concurrently with stop().
  void call(const Callback& fn);
  [[nodiscard]] bool in_loop_thread() const noexcept;

  // Descriptors: EPOLLIN/EPOLLOUT/... (level-triggered); EPOLLHUP and EPOLLERR are always reported.
  // A handler may watch, modify and unwatch any descriptor, its own too.
  void watch(int fd, std::uint32_t events, FdHandler handler);
  void modify(int fd, std::uint32_t events);  // no system call when unchanged
  void unwatch(int fd);

  // Timers: a deadline on CLOCK_MONOTONIC (ns); the callback runs at the first pass at or after it (the
  // timers due at one pass in deadline order).
  // arm(never) disarms; a fired timer is disarmed before its callback runs (which may arm it again).
  Id add_timer(Callback callback);
  void arm(Id timer, std::int64_t deadline_ns);
  void remove_timer(Id timer);

  // Hooks run at every pass after the handlers and timers: wake hooks, settle hooks, end hooks.
  Id add_wake_hook(Callback hook);
  Id add_settle_hook(Callback hook);
  Id add_end_hook(Callback hook);
  void remove_hook(Id hook);
  // A device read data in this pass (devices reading in batches tell each other: their passes are
  // then worth having; a pass where none found any was a wake-up for nothing).
  void data_found() noexcept { data_pass_ = passes_.load(std::memory_order_relaxed); }
  [[nodiscard]] bool data_found_this_pass() const noexcept {
    return data_pass_ == passes_.load(std::memory_order_relaxed);
  }

  // Another pass at once (without sleeping), after this one ends.
  void again() noexcept { again_ = true; }
  // The time this pass began (CLOCK_MONOTONIC, ns): one clock reading shared by everything it runs.
  [[nodiscard]] std::int64_t now() const noexcept { return now_; }
  // Times the loop slept and was woken (by a descriptor, a timer or post()), and passes run.
  [[nodiscard]] std::uint64_t wakeups() const noexcept { return wakeups_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t passes() const noexcept { return passes_.load(std::memory_order_relaxed); }

 private:
  struct Watched {
    std::uint32_t generation = 0;
    std::uint32_t events = 0;
    std::shared_ptr<FdHandler> handler;  // survives unwatch() from inside the handler
  };
  struct Timer {
    Id id = 0;
    std::int64_t deadline = never;
    std::shared_ptr<Callback> callback;
  };
  enum class Stage { wake, settle, end };
  struct Hook {
    Id id = 0;
    Stage stage = Stage::wake;
    std::shared_ptr<Callback> callback;
  };
  Id add_hook(Stage stage, Callback hook);

  void pass(bool woken);
  void run_posted();
  void wait(std::int64_t deadline_ns, bool& woken);
  std::int64_t next_deadline() const noexcept;

  int epoll_fd_ = -1;
  int post_fd_ = -1;   // eventfd: post() and stop()
  int timer_fd_ = -1;  // only where epoll_pwait2 is missing (kernels before 5.11)
  bool use_pwait2_ = true;
  std::int64_t timer_fd_armed_ = never;
  std::unordered_map<int, Watched> watched_;
  std::uint32_t next_generation_ = 0;
  std::vector<Timer> timers_;
  std::vector<std::pair<std::int64_t, Id>> due_;  // a pass's due timers (reused)
  std::vector<Hook> hooks_;
  Id next_id_ = 1;
  bool again_ = false;
  std::uint64_t data_pass_ = 0;
  std::int64_t now_ = 0;
  std::atomic<bool> running_{false};
  std::atomic<bool> stop_requested_{false};
  std::atomic<std::thread::id> thread_id_{};
  std::thread thread_;  // start()'s
  std::mutex posted_mutex_;
  std::vector<Callback> posted_;
  std::atomic<std::uint64_t> wakeups_{0};
  std::atomic<std::uint64_t> passes_{0};
};

}  // namespace guideway::drivers
