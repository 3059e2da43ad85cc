#include "drivers/micrometer/micrometer_driver.hpp"

#include <algorithm>
#include <vector>

#include "core/mono_clock.hpp"

namespace guideway::micrometer {

MicrometerConfig parse_micrometer_config(const TableReader& t) {
  MicrometerConfig c;
  c.endpoint = modbus::parse_endpoint(t);
  if (auto regs = t.table("registers")) {
    c.map = modbus::parse_register_map(*regs);
    regs->reject_unknown_keys();
  }
  c.poll_hz = t.get_double("poll_hz", 50.0, 0.01, 10000.0);
  c.lost_after_failures = static_cast<int>(t.get_int("lost_after_failures", 3, 1, 1000));
  c.backoff_initial = std::chrono::milliseconds(t.get_int("backoff_initial_ms", 100, 1, 600000));
  c.backoff_max = std::chrono::milliseconds(t.get_int("backoff_max_ms", 5000, 1, 3600000));
  if (c.backoff_max < c.backoff_initial) t.fail("backoff_max_ms", "must not be less than backoff_initial_ms");
  return c;
}

MicrometerDriver::MicrometerDriver(std::string name, MicrometerConfig config, std::size_t ring_capacity)
    : Driver(std::move(name), "micrometer-modbus", {{"displacement", "m"}}, ring_capacity),
      config_(std::move(config)) {}

MicrometerDriver::~MicrometerDriver() { stop(); }

void MicrometerDriver::run(std::stop_token stop) {
  modbus::ModbusClient client(config_.endpoint);
  const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / config_.poll_hz));
  const std::uint16_t start = config_.map.block_start();
  const std::uint16_t count = config_.map.block_count();
  std::vector<std::uint16_t> block(count);
  auto backoff = config_.backoff_initial;
  bool ever_connected = false;
  bool gap = false;  // the next sample follows a reconnect or a failed poll

  while (!stop.stop_requested()) {
    set_state(drivers::DeviceState::connecting);
    std::string error;
    if (!client.connect(error)) {
      set_state(drivers::DeviceState::lost, error);
      if (!sleep_for(stop, backoff)) break;
      backoff = std::min(backoff * 2, config_.backoff_max);
      continue;
    }
    if (ever_connected) {
      reconnects_.fetch_add(1, std::memory_order_relaxed);
      gap = true;
    }
    ever_connected = true;
    set_state(drivers::DeviceState::streaming);
    int failures = 0;
    std::string last_failure;
    auto next = std::chrono::steady_clock::now();
    while (!stop.stop_requested()) {
      client.flush();  // stray or duplicated answers must not be taken for the next one
      const modbus::ReadResult r = client.read(config_.map.function, start, count, block);
      const std::int64_t t = mono_now_ns();
      if (r.status == modbus::ReadStatus::ok) {
        frames_.fetch_add(1, std::memory_order_relaxed);
        const modbus::Reading reading = modbus::decode_registers(config_.map, block);
        Sample s;
        s.t_mono_ns = t;
        s.value_count = 1;
        s.value[0] = reading.value_m;
        s.flags = reading.flags | (gap ? sample_after_gap : 0u);
        publish(s);
        gap = false;
        failures = 0;
        backoff = config_.backoff_initial;
      } else if (r.status == modbus::ReadStatus::disconnected) {
        last_failure = "disconnected: " + r.message;
        failures = config_.lost_after_failures;
      } else {
        if (r.status == modbus::ReadStatus::timeout) {
          timeouts_.fetch_add(1, std::memory_order_relaxed);
        } else {
          bad_frames_.fetch_add(1, std::memory_order_relaxed);
          if (r.status == modbus::ReadStatus::exception) exceptions_.fetch_add(1, std::memory_order_relaxed);
        }
        last_failure = std::string(modbus::to_string(r.status)) + ": " + r.message;
        ++failures;
        gap = true;
      }
      if (failures >= config_.lost_after_failures) break;
      next += period;
      const auto now = std::chrono::steady_clock::now();
      if (next < now) next = now;  // late (a timeout ate the period): poll again at once, no catch-up burst
      if (!sleep_for(stop, next - now)) break;
    }
    client.close();
    if (stop.stop_requested()) break;
    set_state(drivers::DeviceState::lost, last_failure);
    if (!sleep_for(stop, backoff)) break;
    backoff = std::min(backoff * 2, config_.backoff_max);
  }
}

void register_micrometer_driver(drivers::DriverRegistry& registry) {
  registry.add("micrometer-modbus", "inductance micrometer (gauge amplifier) over Modbus TCP or RTU, libmodbus",
               [](const drivers::DeviceConfig& c) -> std::unique_ptr<drivers::Driver> {
                 return std::make_unique<MicrometerDriver>(c.name, parse_micrometer_config(c.table), c.ring_capacity);
               });
}

}  // namespace guideway::micrometer
