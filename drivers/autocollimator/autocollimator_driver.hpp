#pragma once
// "autocollimator-serial": a TA80-style two-axis autocollimator on a serial line (see
// autocollimator_protocol.hpp). Polls with "a"/"r" at a period, or starts continuous output and
// listens. One Sample per reading: [angle_x, angle_y] in radians, timestamped when the reply's line
// ended; out-of-range and no-reflection axes are NaN with sample_out_of_range / sample_no_signal.
// Thread safety: as drivers::Driver.

#include <string>

#include "drivers/autocollimator/autocollimator_protocol.hpp"
#include "drivers/driver.hpp"
#include "drivers/serial/serial_port.hpp"

namespace guideway::drivers::autocollimator {

struct AutocollimatorSettings {
  serial::SerialSettings serial;
  bool stream = false;    // false: poll; true: continuous output ("c <ms>")
  bool relative = false;  // "r" instead of "a" (poll mode)
  std::int64_t poll_period_ms = 50;
  std::int64_t stream_period_ms = 20;
  std::int64_t reply_timeout_ms = 300;  // poll: per request; stream: silence before a timeout
  int lost_after_timeouts = 3;          // consecutive timeouts before the state becomes "lost"
  bool require_checksum = false;
  double range_arcsec = 1000.0;  // readings beyond are flagged out of range
  std::int64_t reconnect_min_ms = 50;
  std::int64_t reconnect_max_ms = 5000;
  std::string x_channel = "angle_x";
  std::string y_channel = "angle_y";
};

AutocollimatorSettings parse_autocollimator_settings(const TableReader& table);

// Converts one parsed reading into a sample's values and flags (pure; used by the driver and tests).
void reading_to_sample(const Reading& reading, double range_arcsec, Sample& sample) noexcept;

inline constexpr double arcsec_to_rad = 3.14159265358979323846 / (180.0 * 3600.0);

class AutocollimatorDriver : public drivers::Driver {
 public:
  AutocollimatorDriver(std::string name, std::size_t ring_capacity, AutocollimatorSettings settings);
  ~AutocollimatorDriver() override;

  [[nodiscard]] const AutocollimatorSettings& settings() const noexcept { return settings_; }

 protected:
  void run(std::stop_token stop) override;
  void interrupt() override;

 private:
  std::string serve(const std::stop_token& stop, serial::SerialLine& line);
  void handle_line(const std::string& line, bool& got_reading);

  AutocollimatorSettings settings_;
  int wake_fd_ = -1;
  bool after_gap_ = false;  // driver thread only
  std::int64_t line_end_ns_ = 0;
};

void register_autocollimator_driver(drivers::DriverRegistry& registry);

}  // namespace guideway::drivers::autocollimator
