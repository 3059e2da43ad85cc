#pragma once
// Driver "micrometer-modbus": polls an inductance gauge amplifier over Modbus TCP or RTU and
// publishes one displacement sample (metres) per answered poll. Register map, transport and poll
// rate come from the [[device]] table. Thread safety as drivers::Driver.

#include <chrono>
#include <string>

#include "drivers/driver.hpp"
#include "drivers/modbus/modbus_client.hpp"
#include "drivers/modbus/register_map.hpp"

namespace guideway::micrometer {

struct MicrometerConfig {
  modbus::ModbusEndpoint endpoint;
  modbus::RegisterMap map;
  double poll_hz = 50.0;
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

 protected:
  void run(std::stop_token stop) override;

 private:
  MicrometerConfig config_;
  std::atomic<std::uint64_t> exceptions_{0};
};

void register_micrometer_driver(drivers::DriverRegistry& registry);

}  // namespace guideway::micrometer
