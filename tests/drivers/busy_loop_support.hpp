#pragma once
// Another device on an I/O loop, for the tests of a loop-driven driver that shares it: a timer every
// period_ns keeps the loop passing by, and every pass in which the driver published samples is counted
// as the other device's (its timer ran in that pass) or the driver's own.

#include <cstdint>

#include "core/mono_clock.hpp"
#include "drivers/driver.hpp"
#include "drivers/io_loop.hpp"

namespace guideway::test {

class OtherDeviceOnTheLoop {
 public:
  struct Passes {
    int own = 0;     // the driver published in a pass the other device's timer did not cause
    int others = 0;  // in a pass of the other device's
  };

  OtherDeviceOnTheLoop(drivers::IoLoop& loop, const drivers::Driver& driver, std::int64_t period_ns)
      : loop_(loop), driver_(driver) {
    loop_.call([this, period_ns] {
      timer_ = loop_.add_timer([this, period_ns] {
        other_ = true;
        loop_.arm(timer_, loop_.now() + period_ns);
      });
      loop_.arm(timer_, mono_now_ns() + period_ns);
      hook_ = loop_.add_end_hook([this] {
        const std::uint64_t n = driver_.status().counters.samples;  // produced in this pass or before
        if (n > published_) ++(other_ ? passes_.others : passes_.own);
        published_ = n;
        other_ = false;
      });
    });
  }
  ~OtherDeviceOnTheLoop() { remove(); }
  OtherDeviceOnTheLoop(const OtherDeviceOnTheLoop&) = delete;
  OtherDeviceOnTheLoop& operator=(const OtherDeviceOnTheLoop&) = delete;

  // The passes so far; the other device leaves the loop (call before the loop stops).
  Passes remove() {
    if (timer_ != 0) {
      loop_.call([this] {
        loop_.remove_timer(timer_);
        loop_.remove_hook(hook_);
      });
      timer_ = 0;
    }
    return passes_;
  }

 private:
  drivers::IoLoop& loop_;
  const drivers::Driver& driver_;
  drivers::IoLoop::Id timer_ = 0;
  drivers::IoLoop::Id hook_ = 0;
  // The loop thread's (read by remove() after the loop's call returned).
  bool other_ = false;
  std::uint64_t published_ = 0;
  Passes passes_;
};

}  // namespace guideway::test
