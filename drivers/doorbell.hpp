#pragma once
// Wakes the pipeline thread when a driver publishes while it sleeps. A driver never blocks and pays
// a system call (FUTEX_WAKE) only when the consumer is actually asleep: the consumer arms the bell,
// looks at the rings once more, and only then waits. Otherwise a ring costs one atomic exchange.
// Thread safety: ring() from any number of producers; arm()/wait_for()/disarm() from one consumer.

#include <linux/futex.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <ctime>

namespace guideway::drivers {

class Doorbell {
 public:
  // Producer, after its data is visible (the ring's release store): wakes a sleeping consumer.
  // The read-modify-writes on `armed_` on both sides order themselves (acquire/release on one atomic,
  // no fences, which TSan cannot check): either the consumer's arm() comes after this exchange and
  // so sees our data when it looks again, or this exchange sees it armed and wakes it.
  void ring() noexcept {
    if (armed_.exchange(0, std::memory_order_acq_rel) != 0) {
      futex(FUTEX_WAKE_PRIVATE, 1, nullptr);
      wakes_.fetch_add(1, std::memory_order_relaxed);
    }
  }
  // Consumer: announce the intent to sleep, then check for data once more before wait_for().
  void arm() noexcept { (void)armed_.exchange(1, std::memory_order_acq_rel); }
  // Consumer: sleeps until ring() or the timeout (spurious returns are harmless); leaves it disarmed.
  void wait_for(std::int64_t timeout_ns) noexcept {
    const timespec ts{static_cast<time_t>(timeout_ns / 1'000'000'000), static_cast<long>(timeout_ns % 1'000'000'000)};
    futex(FUTEX_WAIT_PRIVATE, 1, &ts);  // returns at once if a producer already disarmed it
    disarm();
  }
  // An exchange, not a store: it keeps the release sequence of the producers' exchanges unbroken, so
  // the next arm() synchronises with every ring() before it (C++ model; x86 and ARMv8 would not need it).
  void disarm() noexcept { (void)armed_.exchange(0, std::memory_order_acq_rel); }
  // Wake-ups delivered by a system call (for tests and debugging).
  [[nodiscard]] std::uint64_t wakes() const noexcept { return wakes_.load(std::memory_order_relaxed); }

 private:
  void futex(int op, int value, const timespec* timeout) noexcept {
    static_assert(sizeof(std::atomic<std::uint32_t>) == sizeof(std::uint32_t));
    (void)::syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&armed_), op, value, timeout, nullptr, 0);
  }

  std::atomic<std::uint32_t> armed_{0};
  std::atomic<std::uint64_t> wakes_{0};
};

}  // namespace guideway::drivers
