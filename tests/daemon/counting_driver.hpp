#pragma once
// A real driver thread with no transport: it publishes `rate_hz` samples per second (config key,
// default 2000, its full rate: its ring is the rule's for it) whose one value is its own count, so
// pipeline, sessions and recordings can be checked exactly; with `nan_every = N` every Nth value is NaN
// flagged "no signal" (a lost beam).

#include <chrono>
#include <limits>
#include <thread>

#include "core/mono_clock.hpp"
#include "drivers/driver.hpp"

namespace guideway::test {

class CountingDriver : public drivers::Driver {
 public:
  explicit CountingDriver(const drivers::DeviceConfig& c)
      : Driver(c.name, c.driver, {{"count", "1"}}, c.ring_for(rate_of(c.table))),
        rate_hz_(rate_of(c.table)),
        nan_every_(c.table.get_int("nan_every", 0, 0, 1 << 20)) {}
  ~CountingDriver() override { stop(); }

 protected:
  void run(std::stop_token stop) override {
    set_state(drivers::DeviceState::streaming);
    const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / rate_hz_));
    auto next = std::chrono::steady_clock::now();
    double n = 0;
    while (!stop.stop_requested()) {
      Sample s;
      s.t_mono_ns = mono_now_ns();
      s.value_count = 1;
      s.value[0] = n++;
      if (nan_every_ != 0 && static_cast<std::int64_t>(s.value[0]) % nan_every_ == 0) {
        s.value[0] = std::numeric_limits<double>::quiet_NaN();
        s.flags = sample_no_signal;
      }
      publish(s);
      frames_.fetch_add(1, std::memory_order_relaxed);
      next += period;
      std::this_thread::sleep_until(next);
    }
  }

 private:
  static double rate_of(const TableReader& table) { return table.get_double("rate_hz", 2000.0, 1.0, 1e7); }
  double rate_hz_;
  std::int64_t nan_every_;
};

}  // namespace guideway::test
