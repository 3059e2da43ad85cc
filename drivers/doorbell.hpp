#pragma once
// Wakes the pipeline's loop when a driver on a thread of its own publishes while the loop sleeps. A
// driver never blocks and pays a system call (an eventfd write) only when the consumer is actually
// asleep: the consumer arms the bell, looks at the rings once more, and only then sleeps with the
// bell's descriptor in its wait (IoLoop). Otherwise a ring costs one atomic exchange. Drivers served
// by the consumer's own loop do not ring it: the pipeline runs after them in the same pass.
// Thread safety: ring() from any number of producers; arm()/disarm()/clear()/wait_for() from one consumer.

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <ctime>
#include <system_error>

namespace guideway::drivers {

class Doorbell {
 public:
  Doorbell() : fd_(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK)) {
    if (fd_ < 0) throw std::system_error(errno, std::generic_category(), "eventfd");
  }
  ~Doorbell() { ::close(fd_); }
  Doorbell(const Doorbell&) = delete;
  Doorbell& operator=(const Doorbell&) = delete;

  // Readable after a ring() that found the consumer armed: the consumer waits on it.
  [[nodiscard]] int fd() const noexcept { return fd_; }
  // Producer, after its data is visible (the ring's release store): wakes a sleeping consumer.
  // The read-modify-writes on `armed_` on both sides order themselves (acquire/release on one atomic,
  // no fences, which TSan cannot check): either the consumer's arm() comes after this exchange and
  // so sees our data when it looks again, or this exchange sees it armed and wakes it.
  void ring() noexcept {
    if (armed_.exchange(0, std::memory_order_acq_rel) != 0) {
      const std::uint64_t one = 1;
      (void)!::write(fd_, &one, sizeof one);
      wakes_.fetch_add(1, std::memory_order_relaxed);
    }
  }
  // Consumer: announce the intent to sleep, then check for data once more before sleeping.
  void arm() noexcept { (void)armed_.exchange(1, std::memory_order_acq_rel); }
  // An exchange, not a store: it keeps the release sequence of the producers' exchanges unbroken, so
  // the next arm() synchronises with every ring() before it (C++ model; x86 and ARMv8 would not need it).
  void disarm() noexcept { (void)armed_.exchange(0, std::memory_order_acq_rel); }
  // Consumer, woken by fd(): takes the wake-up, so the descriptor is quiet until the next one.
  void clear() noexcept {
    std::uint64_t count = 0;
    (void)!::read(fd_, &count, sizeof count);
  }
  // Consumer without a loop: sleeps until ring() or the timeout (spurious returns are harmless);
  // leaves it disarmed.
  void wait_for(std::int64_t timeout_ns) noexcept {
    pollfd p{fd_, POLLIN, 0};
    const timespec ts{static_cast<time_t>(timeout_ns / 1'000'000'000), static_cast<long>(timeout_ns % 1'000'000'000)};
    (void)::ppoll(&p, 1, &ts, nullptr);  // returns at once if a producer already rang
    disarm();
    clear();
  }
  // Wake-ups delivered by a system call (for tests and debugging).
  [[nodiscard]] std::uint64_t wakes() const noexcept { return wakes_.load(std::memory_order_relaxed); }

 private:
  int fd_;
  std::atomic<std::uint32_t> armed_{0};
  std::atomic<std::uint64_t> wakes_{0};
};

}  // namespace guideway::drivers
