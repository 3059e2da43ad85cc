// One thread's epoll loop serving many devices (io_loop.hpp): fds with handlers, nanosecond timers, hooks once per
// wake-up.
#include "drivers/io_loop.hpp"

#include <pthread.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/prctl.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <exception>
#include <future>
#include <system_error>

#include "core/mono_clock.hpp"

namespace guideway::drivers {

namespace {

constexpr std::uint64_t post_key = ~std::uint64_t{0};
constexpr std::uint64_t timer_key = ~std::uint64_t{0} - 1;

timespec to_timespec(std::int64_t ns) noexcept {
  return {static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
}

}  // namespace

IoLoop::IoLoop() {
  epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd_ < 0) throw std::system_error(errno, std::generic_category(), "epoll_create1");
  post_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (post_fd_ < 0) {
    const int err = errno;
    ::close(epoll_fd_);
    throw std::system_error(err, std::generic_category(), "eventfd");
  }
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.u64 = post_key;
  (void)::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, post_fd_, &ev);
}

IoLoop::~IoLoop() {
  stop();
  ::close(post_fd_);
  if (timer_fd_ >= 0) ::close(timer_fd_);
  ::close(epoll_fd_);
}

bool IoLoop::in_loop_thread() const noexcept {
  return thread_id_.load(std::memory_order_acquire) == std::this_thread::get_id();
}

void IoLoop::start(const std::string& thread_name) {
  if (thread_.joinable()) return;
  std::promise<void> started;
  auto running = started.get_future();
  stop_requested_.store(false, std::memory_order_relaxed);
  thread_ = std::thread([this, thread_name, &started] {
    (void)::pthread_setname_np(::pthread_self(), thread_name.substr(0, 15).c_str());
    thread_id_.store(std::this_thread::get_id(), std::memory_order_release);
    running_.store(true, std::memory_order_release);
    started.set_value();
    run();
  });
  running.wait();
}

void IoLoop::stop() {
  stop_requested_.store(true, std::memory_order_release);
  const std::uint64_t one = 1;
  (void)!::write(post_fd_, &one, sizeof one);
  if (thread_.joinable() && thread_.get_id() != std::this_thread::get_id()) thread_.join();
}

void IoLoop::post(Callback fn) {
  bool first = false;
  {
    std::lock_guard lock(posted_mutex_);
    first = posted_.empty();
    posted_.push_back(std::move(fn));
  }
  if (first) {
    const std::uint64_t one = 1;
    (void)!::write(post_fd_, &one, sizeof one);
  }
}

void IoLoop::call(const Callback& fn) {
  if (in_loop_thread() || !running_.load(std::memory_order_acquire)) {
    fn();
    return;
  }
  std::promise<void> done;
  auto finished = done.get_future();
  post([&] {
    try {
      fn();
      done.set_value();
    } catch (...) {  // thrown to the caller, not out of the loop's thread
      done.set_exception(std::current_exception());
    }
  });
  finished.get();
}

void IoLoop::run_posted() {
  std::uint64_t count = 0;
  (void)!::read(post_fd_, &count, sizeof count);
  std::vector<Callback> batch;
  {
    std::lock_guard lock(posted_mutex_);
    batch.swap(posted_);
  }
  for (auto& fn : batch) fn();
}

void IoLoop::watch(int fd, std::uint32_t events, FdHandler handler) {
  Watched& w = watched_[fd];
  const bool existing = w.handler != nullptr;
  w.generation = ++next_generation_;
  w.events = events;
  w.handler = std::make_shared<FdHandler>(std::move(handler));
  epoll_event ev{};
  ev.events = events;
  ev.data.u64 = (std::uint64_t{w.generation} << 32) | static_cast<std::uint32_t>(fd);
  if (::epoll_ctl(epoll_fd_, existing ? EPOLL_CTL_MOD : EPOLL_CTL_ADD, fd, &ev) != 0) {
    const int err = errno;
    watched_.erase(fd);
    throw std::system_error(err, std::generic_category(), "epoll_ctl(watch)");
  }
}

void IoLoop::modify(int fd, std::uint32_t events) {
  auto it = watched_.find(fd);
  if (it == watched_.end() || it->second.events == events) return;
  it->second.events = events;
  epoll_event ev{};
  ev.events = events;
  ev.data.u64 = (std::uint64_t{it->second.generation} << 32) | static_cast<std::uint32_t>(fd);
  (void)::epoll_ctl(epoll_fd_, EPOLL_CTL_MOD, fd, &ev);
}

void IoLoop::unwatch(int fd) {
  if (watched_.erase(fd) == 0) return;
  (void)::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, fd, nullptr);
}

IoLoop::Id IoLoop::add_timer(Callback callback) {
  const Id id = next_id_++;
  timers_.push_back({id, never, std::make_shared<Callback>(std::move(callback))});
  return id;
}

void IoLoop::arm(Id timer, std::int64_t deadline_ns) {
  for (Timer& t : timers_) {
    if (t.id == timer) {
      t.deadline = deadline_ns;
      return;
    }
  }
}

void IoLoop::remove_timer(Id timer) {
  // Left in place as a tombstone (a pass may be iterating over the timers); compacted after the pass.
  for (Timer& t : timers_) {
    if (t.id == timer) {
      t = Timer{};
      return;
    }
  }
}

IoLoop::Id IoLoop::add_hook(Stage stage, Callback hook) {
  const Id id = next_id_++;
  hooks_.push_back({id, stage, std::make_shared<Callback>(std::move(hook))});
  return id;
}

IoLoop::Id IoLoop::add_wake_hook(Callback hook) { return add_hook(Stage::wake, std::move(hook)); }
IoLoop::Id IoLoop::add_settle_hook(Callback hook) { return add_hook(Stage::settle, std::move(hook)); }
IoLoop::Id IoLoop::add_end_hook(Callback hook) { return add_hook(Stage::end, std::move(hook)); }

void IoLoop::remove_hook(Id hook) {
  for (Hook& h : hooks_) {
    if (h.id == hook) {
      h = Hook{};
      return;
    }
  }
}

std::int64_t IoLoop::next_deadline() const noexcept {
  std::int64_t next = never;
  for (const Timer& t : timers_) next = std::min(next, t.deadline);
  return next;
}

void IoLoop::run() {
  if (!in_loop_thread()) {
    thread_id_.store(std::this_thread::get_id(), std::memory_order_release);
    running_.store(true, std::memory_order_release);
  }
  // Wake-ups at most 10 us late (the default slack is 50 us): SYNC periods of 100 us keep their phase.
  (void)::prctl(PR_SET_TIMERSLACK, 10'000UL, 0UL, 0UL, 0UL);
  std::array<epoll_event, 64> events{};
  now_ = mono_now_ns();
  while (!stop_requested_.load(std::memory_order_acquire)) {
    const std::int64_t deadline = again_ ? 0 : next_deadline();
    again_ = false;
    int n = 0;
    if (use_pwait2_) {
      timespec ts{};
      const timespec* timeout = nullptr;
      if (deadline != never) {
        ts = to_timespec(std::max<std::int64_t>(deadline - mono_now_ns(), 0));
        timeout = &ts;
      }
      n = ::epoll_pwait2(epoll_fd_, events.data(), static_cast<int>(events.size()), timeout, nullptr);
      if (n < 0 && errno == ENOSYS) {
        // Kernels before 5.11: a timerfd in the set gives the deadline its nanoseconds.
        use_pwait2_ = false;
        timer_fd_ = ::timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC | TFD_NONBLOCK);
        if (timer_fd_ < 0) throw std::system_error(errno, std::generic_category(), "timerfd_create");
        epoll_event ev{};
        ev.events = EPOLLIN;
        ev.data.u64 = timer_key;
        (void)::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, timer_fd_, &ev);
        continue;
      }
      if (deadline != 0 && (timeout == nullptr || ts.tv_sec != 0 || ts.tv_nsec != 0))
        wakeups_.fetch_add(1, std::memory_order_relaxed);
    } else {
      const std::int64_t before = mono_now_ns();
      if (deadline != timer_fd_armed_ && deadline > before) {
        const itimerspec at{{0, 0}, to_timespec(deadline == never ? 0 : deadline)};
        (void)::timerfd_settime(timer_fd_, TFD_TIMER_ABSTIME, &at, nullptr);
        timer_fd_armed_ = deadline;
      }
      const bool sleeps = deadline > before;
      n = ::epoll_wait(epoll_fd_, events.data(), static_cast<int>(events.size()), sleeps ? -1 : 0);
      if (sleeps) wakeups_.fetch_add(1, std::memory_order_relaxed);
    }
    if (n < 0) {
      if (errno != EINTR) throw std::system_error(errno, std::generic_category(), "epoll_pwait2");
      n = 0;
    }
    now_ = mono_now_ns();
    passes_.fetch_add(1, std::memory_order_relaxed);
    for (int i = 0; i < n; ++i) {
      const std::uint64_t key = events[static_cast<std::size_t>(i)].data.u64;
      if (key == post_key) {
        run_posted();
        continue;
      }
      if (key == timer_key) {
        std::uint64_t expirations = 0;
        (void)!::read(timer_fd_, &expirations, sizeof expirations);
        timer_fd_armed_ = never;
        continue;
      }
      const int fd = static_cast<int>(key & 0xFFFFFFFFu);
      const auto it = watched_.find(fd);
      // Unwatched (or watched anew) by an earlier handler of this pass: the event is stale.
      if (it == watched_.end() || it->second.generation != static_cast<std::uint32_t>(key >> 32)) continue;
      const std::shared_ptr<FdHandler> handler = it->second.handler;
      (*handler)(events[static_cast<std::size_t>(i)].events);
    }
    // The due timers, earliest deadline first (a late pass may find several due).
    bool tombstones = false;
    due_.clear();
    for (const Timer& t : timers_) {
      if (t.id == 0) tombstones = true;
      if (t.id != 0 && t.deadline <= now_) due_.emplace_back(t.deadline, t.id);
    }
    std::sort(due_.begin(), due_.end());
    for (const auto& [due_at, id] : due_) {
      // Looked up again: an earlier callback may have removed, re-armed or added timers.
      const auto it = std::find_if(timers_.begin(), timers_.end(), [id = id](const Timer& t) { return t.id == id; });
      if (it == timers_.end() || it->deadline != due_at) continue;
      it->deadline = never;
      const std::shared_ptr<Callback> callback = it->callback;
      (*callback)();
    }
    for (const Stage stage : {Stage::wake, Stage::settle, Stage::end}) {
      for (std::size_t i = 0; i < hooks_.size(); ++i) {
        if (hooks_[i].id == 0) {
          tombstones = true;
          continue;
        }
        if (hooks_[i].stage != stage) continue;
        const std::shared_ptr<Callback> hook = hooks_[i].callback;
        (*hook)();
      }
    }
    if (tombstones) {
      std::erase_if(timers_, [](const Timer& t) { return t.id == 0; });
      std::erase_if(hooks_, [](const Hook& h) { return h.id == 0; });
    }
  }
  run_posted();  // a call() that raced with stop() is not left waiting
  running_.store(false, std::memory_order_release);
  thread_id_.store(std::thread::id{}, std::memory_order_release);
}

}  // namespace guideway::drivers
