#pragma once
// The driver API. A driver owns one device: it reads the transport, parses frames with a pure
// parser, timestamps samples with CLOCK_MONOTONIC and pushes them into its SPSC ring (it is the
// ring's only producer). Faults are states of the driver, never exceptions out of it.
// Two kinds: a loop-driven driver is a non-blocking state machine fed by descriptor readiness and
// timers of an IoLoop (drivers/io_loop.hpp), so one thread serves many devices; any other driver
// (a blocking vendor library, a plugin) runs run() on a thread of its own.
// Thread safety: start/stop from the owning thread; status() and ring observers from any thread;
// ring().try_pop/pop_bulk from the single consumer (the pipeline).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <stop_token>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "core/sample.hpp"
#include "core/spsc_ring.hpp"
#include "core/toml_access.hpp"
#include "drivers/doorbell.hpp"

namespace guideway::drivers {

enum class DeviceState { stopped, connecting, streaming, lost, error };

// How long a loop-driven driver that streams rests between reads of its transport (its
// `read_period_us`, 0: a wake-up per arrival): what arrived meanwhile waits in the socket, then the
// pipeline runs in the same wake-up, so a sample waits at most this plus the hop to the clients
// (docs/architecture.md, "Threads"). Every streaming driver has the same default, so the devices of
// one loop read in step and share one wake-up per period.
inline constexpr std::int64_t default_read_period_us = 700;
std::string_view to_string(DeviceState state) noexcept;

struct ChannelInfo {
  std::string name;  // e.g. "bar_length", "x", "pitch"
  std::string unit;  // SI unit of the ring values: "m", "rad", "s"
};

struct DriverCounters {
  std::uint64_t samples = 0;     // samples produced (pushed or dropped)
  std::uint64_t frames = 0;      // frames/lines/responses received and parsed
  std::uint64_t bad_frames = 0;  // garbage, CRC errors, truncated or unparseable input
  std::uint64_t timeouts = 0;    // requests that got no answer in time
  std::uint64_t reconnects = 0;  // successful connections after the first
  std::uint64_t overruns = 0;    // samples dropped because the ring was full
};

// A count a driver keeps beyond DriverCounters, e.g. the micrometer's lost_samples: `name` is
// snake_case, says what it counts and never changes (docs/protocol.md lists every one).
struct NamedCounter {
  std::string name;
  std::uint64_t value = 0;
};

// Something that happened to a device besides a change of its state (a CANopen node's EMCY, a node
// that rebooted): the daemon logs it and sends it as an EVENT with the device's name.
struct DeviceEvent {
  std::string event;    // snake_case, a fixed name per kind ("node_emcy", "node_boot", ...)
  std::string reason;   // what happened, naming the part of the device it concerns
  bool warning = true;  // logged as a warning (else as information)
};

struct RingStatus {
  std::size_t capacity = 0;
  std::size_t depth = 0;
  std::size_t free = 0;
  std::uint64_t drops = 0;
};

struct DriverStatus {
  std::string name;
  std::string driver;
  DeviceState state = DeviceState::stopped;
  std::string reason;  // why the state is what it is ("", "connection refused", ...)
  // What the user should know whatever the state, e.g. an instrument whose serial is not the configured one.
  std::vector<std::string> warnings;
  DriverCounters counters;
  std::vector<NamedCounter>
      driver_counters;  // Driver::driver_counters(), in the driver's order (STATUS's JSON object sorts them by name)
  RingStatus ring;
};

class IoLoop;

class Driver {
 public:
  Driver(std::string name, std::string driver, std::vector<ChannelInfo> channels, std::size_t ring_capacity);
  virtual ~Driver();
  Driver(const Driver&) = delete;
  Driver& operator=(const Driver&) = delete;

  // Starts serving the device: a loop-driven driver on `loop` when one is given (guidewayd's I/O
  // thread), else on an IoLoop of its own thread; any other driver runs run() on its own thread.
  // `loop` must outlive the device's service (stop() first).
  void start(IoLoop* loop = nullptr);
  // A loop-driven driver: detach() on its loop's thread (its own loop then ends); else requests stop,
  // wakes the thread (interrupt()) and joins. Nothing received before is lost.
  void stop();
  // Whether this driver is served by an IoLoop (attach/detach) rather than a thread running run().
  [[nodiscard]] virtual bool loop_driven() const noexcept { return false; }
  [[nodiscard]] DriverStatus status() const;
  // The driver's own counters (STATUS "driver_counters"), the same names every time; default none.
  // Called from any thread while run() goes on: read atomics only.
  [[nodiscard]] virtual std::vector<NamedCounter> driver_counters() const { return {}; }
  // The events posted since the last call, oldest first (any thread; the daemon polls it with the
  // states). At most max_pending_events wait: older ones are dropped, and an "events_dropped" event
  // says how many.
  std::vector<DeviceEvent> take_events();
  static constexpr std::size_t max_pending_events = 256;
  [[nodiscard]] const std::string& name() const noexcept { return name_; }
  [[nodiscard]] const std::string& driver() const noexcept { return driver_; }
  [[nodiscard]] const std::vector<ChannelInfo>& channels() const noexcept { return channels_; }
  SpscRing<Sample>& ring() noexcept { return ring_; }
  [[nodiscard]] std::size_t ring_capacity() const noexcept { return ring_.capacity(); }
  // The consumer's bell, rung after every publish (nullptr: none). The bell must outlive the
  // driver's publishing: stop the driver before destroying it (clearing it is not enough: a publish
  // in flight may already hold the pointer).
  void set_doorbell(Doorbell* bell) noexcept { doorbell_.store(bell, std::memory_order_release); }

 protected:
  // A threaded driver's thread: connect, read, parse, publish; on a fault set_state(lost/error), back
  // off, reconnect. Must return promptly once stop is requested.
  virtual void run(std::stop_token stop) { (void)stop; }
  // Called from stop() on the owning thread to unblock a run() waiting on I/O (e.g. write an eventfd).
  virtual void interrupt() {}
  // A loop-driven driver, on the loop's thread: attach() connects (or schedules the connection) and
  // watches its descriptors and timers, never blocking; the handlers do the rest (reconnect with
  // back-off included). detach() removes every descriptor, timer and hook, closes the device and
  // publishes what it still holds. Everything the two touch is the loop thread's.
  virtual void attach(IoLoop& loop) { (void)loop; }
  virtual void detach() {}

  void set_state(DeviceState state, std::string reason = {});
  // Replaces the device's standing warnings (status().warnings); any thread, a mutex held for a swap.
  void set_warnings(std::vector<std::string> warnings);
  // What the device's configuration says for as long as the device runs (a key by its old name), listed in
  // status().warnings after set_warnings()'s, which do not replace them.
  void set_config_warnings(std::vector<std::string> warnings);
  // Queues an event for take_events(); never blocks for long (a mutex held for a push).
  void post_event(DeviceEvent event);
  // Assigns the sequence number and pushes; a full ring counts an overrun (the sample is dropped).
  void publish(Sample sample) noexcept;
  // n samples the instrument took that never reached the driver (its own buffer lapped): their
  // sequence numbers are skipped, so the pipeline counts them in seq_gaps and `samples` includes them.
  void skip_samples(std::uint64_t n) noexcept;
  // Sleeps for d unless stop is requested first; returns false when stopping.
  static bool sleep_for(const std::stop_token& stop, std::chrono::nanoseconds d);
  // The one rule of `streaming` (docs/protocol.md, "Device states"): a device with a sample bound (the
  // longest it goes without a sample while it works: its period, its timeouts) is shown `streaming`
  // only while samples arrive within it. Until its link's first sample status() shows `connecting`
  // ("waiting for the first sample"), then `lost` ("no sample for more than N ms") once the bound
  // passes; from its next sample what the driver set again. 0 (the default): the state as set. Set it
  // before start().
  void set_sample_bound(std::chrono::nanoseconds bound) noexcept {
    sample_bound_ns_.store(bound.count(), std::memory_order_relaxed);
  }
  // A new link to the device (the producer thread): the samples that count for `streaming` from now on.
  void mark_link_up();
  // Samples published so far (the producer thread; skipped ones not included).
  [[nodiscard]] std::uint64_t published_samples() const noexcept {
    return published_.load(std::memory_order_relaxed);
  }

  std::atomic<std::uint64_t> frames_{0};
  std::atomic<std::uint64_t> bad_frames_{0};
  std::atomic<std::uint64_t> timeouts_{0};
  std::atomic<std::uint64_t> reconnects_{0};

 private:
  // status(): `streaming` as the sample bound allows it (set_sample_bound).
  void apply_sample_bound(DriverStatus& s) const;

  std::string name_;
  std::string driver_;
  std::vector<ChannelInfo> channels_;
  SpscRing<Sample> ring_;
  std::atomic<Doorbell*> doorbell_{nullptr};
  std::uint64_t next_seq_ = 0;  // producer thread only
  std::atomic<std::uint64_t> samples_{0};
  std::atomic<std::uint64_t> published_{0};
  std::atomic<std::int64_t> last_sample_ns_{0};  // the newest published sample's time
  std::atomic<std::int64_t> sample_bound_ns_{0};
  std::int64_t link_up_ns_ = 0;                // under state_mutex_: mark_link_up()'s
  std::uint64_t published_at_link_up_ = 0;     // under state_mutex_
  std::uint64_t bad_frames_at_link_up_ = 0;    // under state_mutex_
  mutable std::mutex state_mutex_;
  DeviceState state_ = DeviceState::stopped;
  std::string reason_;
  std::vector<std::string> warnings_;  // under state_mutex_
  std::vector<std::string> config_warnings_;  // under state_mutex_
  std::vector<DeviceEvent> events_;   // under state_mutex_
  std::uint64_t events_dropped_ = 0;  // under state_mutex_
  std::jthread thread_;
  IoLoop* loop_ = nullptr;            // serving a loop-driven driver (owning thread)
  std::unique_ptr<IoLoop> own_loop_;  // when it was started without one
};

// A [[device]] table of the configuration. The factory reads its own keys from `table` (and must read
// every key it accepts, so unknown keys are rejected with file and line).
struct DeviceConfig {
  std::string name;
  std::string driver;
  // The ring the configuration gives (the device's ring_capacity, else [daemon]'s); nullopt: the rule's.
  std::optional<std::size_t> ring_capacity;
  const TableReader& table;
  // The device's ring for its full rate (drivers/ring_capacity.hpp): the rule's, or the configuration's when
  // it gives one no smaller (a smaller one is a ConfigError naming the key, the rate and the least).
  [[nodiscard]] std::size_t ring_for(double full_rate_hz) const;
};

using DriverFactory = std::function<std::unique_ptr<Driver>(const DeviceConfig&)>;

class DriverRegistry {
 public:
  void add(std::string driver, std::string description, DriverFactory factory);
  [[nodiscard]] bool contains(std::string_view driver) const;
  // Throws ConfigError (naming the known drivers) when the driver is unknown.
  std::unique_ptr<Driver> create(const DeviceConfig& config) const;
  [[nodiscard]] std::vector<std::pair<std::string, std::string>> list() const;  // (driver, description)

  // Adds the driver of every *.so in dir that exports guideway_driver_plugin() (drivers/plugin_abi.h);
  // returns one message per file refused, naming it (the caller logs them). A missing dir is not an error.
  std::vector<std::string> load_plugins(const std::string& dir);

 private:
  struct Entry {
    std::string driver;
    std::string description;
    DriverFactory factory;
  };
  std::vector<Entry> entries_;
  std::vector<void*> plugin_handles_;
};

// The plugin directory next to the running executable (<exe>/../lib/guideway/plugins, which is
// where both the build tree and an installation put them), else the compiled-in install path.
std::string default_plugin_dir();

}  // namespace guideway::drivers
