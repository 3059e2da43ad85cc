#pragma once
// Driver "micrometer-modbus": reads an inductance gauge amplifier over Modbus TCP or RTU.
// Polled mode (default): one read of the [registers] block per poll, one displacement sample
// (metres) per answer. Buffered mode ([buffer] table): the amplifier keeps its recent samples in a
// ring of registers with a sample counter; every poll_period_ms the driver reads the counter and
// the new part of the ring, publishes every sample once, timestamped from its sample number, and
// counts what the ring lost between polls. Register maps, transport and rates come from the
// [[device]] table (docs/protocols.md). Thread safety as drivers::Driver.

#include <chrono>
#include <optional>
#include <string>

#include "drivers/driver.hpp"
#include "drivers/modbus/modbus_client.hpp"
#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/sample_ring.hpp"

namespace guideway::drivers::micrometer {

// Buffered mode's default poll period: favours CPU over latency (docs/protocols.md, "Buffered acquisition").
inline constexpr double default_buffer_poll_period_ms = 5.0;

struct MicrometerConfig {
  modbus::ModbusEndpoint endpoint;
  modbus::RegisterMap map;                     // polled mode
  double poll_hz = 50.0;                       // polled mode
  std::optional<modbus::SampleRingMap> buffer;  // set: buffered mode
  double poll_period_ms = default_buffer_poll_period_ms;  // buffered mode
  int lost_after_failures = 3;  // consecutive failed polls before the link is declared lost
  std::chrono::milliseconds backoff_initial{100};
  std::chrono::milliseconds backoff_max{5000};
};

// Reads every key the driver accepts (throws ConfigError naming file:line:key).
MicrometerConfig parse_micrometer_config(const TableReader& table);

class MicrometerDriver : public drivers::Driver {
 public:
  MicrometerDriver(std::string name, MicrometerConfig config, std::size_t ring_capacity);
  ~MicrometerDriver() override;
  [[nodiscard]] const MicrometerConfig& config() const noexcept { return config_; }
  // Failed polls answered with a Modbus exception (also counted in bad_frames).
  [[nodiscard]] std::uint64_t exceptions() const noexcept { return exceptions_.load(std::memory_order_relaxed); }
  // Buffered mode: polls that found samples overwritten by the amplifier's ring (once per poll, however
  // many of its reads saw it), and the samples lost so
  // (also skipped sequence numbers: the pipeline's seq_gaps); counter resets (amplifier restarted).
  [[nodiscard]] std::uint64_t ring_overruns() const noexcept { return ring_overruns_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t lost_samples() const noexcept { return lost_samples_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t counter_resets() const noexcept {
    return counter_resets_.load(std::memory_order_relaxed);
  }
  // exceptions, ring_overruns, lost_samples, counter_resets (the last three stay 0 in polled mode).
  [[nodiscard]] std::vector<drivers::NamedCounter> driver_counters() const override {
    const std::uint64_t lost = lost_samples_.load(std::memory_order_acquire);  // before the overruns: see lose()
    return {{"exceptions", exceptions()},
            {"ring_overruns", ring_overruns()},
            {"lost_samples", lost},
            {"counter_resets", counter_resets()},
            {"stale_answers", stale_answers_.load(std::memory_order_relaxed)}};
  }

 protected:
  void run(std::stop_token stop) override;

 private:
  struct RingCursor;
  // The inner loops of one connection; each returns why the link was given up ("" when stopping).
  std::string stream_polled(const std::stop_token& stop, modbus::ModbusClient& client,
                            std::chrono::milliseconds& backoff, bool& gap);
  std::string stream_buffered(const std::stop_token& stop, modbus::ModbusClient& client,
                              std::chrono::milliseconds& backoff, RingCursor& cursor);
  // A failed request of either mode: counted (timeout, bad frame, exception; a lost link is not a
  // frame), and the reason to report.
  std::string count_failure(const modbus::ReadResult& r);
  void lose(RingCursor& cursor, std::uint64_t n) noexcept;
  // Takes the late answers the client discarded since the last call into the counters.
  void count_stale(const modbus::ModbusClient& client) noexcept;

  MicrometerConfig config_;
  std::atomic<std::uint64_t> exceptions_{0};
  std::atomic<std::uint64_t> ring_overruns_{0};
  std::atomic<std::uint64_t> lost_samples_{0};
  std::atomic<std::uint64_t> counter_resets_{0};
  std::atomic<std::uint64_t> stale_answers_{0};  // RTU: late answers discarded before a read (also bad frames)
  std::uint64_t stale_seen_ = 0;                 // the client's count already taken (driver thread only)
};

void register_micrometer_driver(drivers::DriverRegistry& registry);

}  // namespace guideway::drivers::micrometer
