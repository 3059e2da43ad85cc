#pragma once
// "autocollimator-serial": a TA80-style two-axis autocollimator on a serial line (see
// autocollimator_protocol.hpp). Polls with "a"/"r" at a period, or starts continuous output and
// listens. One Sample per reading: [angle_x, angle_y] in radians, timestamped when the reply's line
// was read (a serial line carries no arrival times: up to read_period_us after it ended when the
// driver reads in batches); out-of-range and no-reflection axes are NaN with sample_out_of_range /
// sample_no_signal. On the driver skeleton (drivers/loop_driver.hpp): requests are written without
// waiting, replies read as the line becomes readable (in stream mode at a read period).
// Thread safety: as drivers::Driver.

#include <string>

#include "drivers/autocollimator/autocollimator_protocol.hpp"
#include "drivers/loop_driver.hpp"
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
  drivers::Reconnect reconnect{Backoff{0.05, 5.0}, {}};  // reconnect_min_ms 50, reconnect_max_ms 5000
  std::string x_channel = "angle_x";
  std::string y_channel = "angle_y";
  // Stream mode with lines less than two read periods apart: rest this long between reads while
  // readings flow (0: a wake-up per line). Readings are then stamped when read, up to this late.
  std::int64_t read_period_us = drivers::default_read_period_us;
};

AutocollimatorSettings parse_autocollimator_settings(const TableReader& table);

// Converts one parsed reading into a sample's values and flags (pure; used by the driver and tests).
void reading_to_sample(const Reading& reading, double range_arcsec, Sample& sample) noexcept;

inline constexpr double arcsec_to_rad = 3.14159265358979323846 / (180.0 * 3600.0);

class AutocollimatorDriver : public drivers::LoopDriver {
 public:
  AutocollimatorDriver(std::string name, std::size_t ring_capacity, AutocollimatorSettings settings);
  ~AutocollimatorDriver() override;

  [[nodiscard]] const AutocollimatorSettings& settings() const noexcept { return settings_; }

 protected:
  void open() override;
  void on_link_up(std::int64_t now_ns) override;
  // Reads what the line holds (at most max_read_bytes: a flooding line waits for the others).
  drivers::ReadOutcome read_some(bool at_others_pass) override;
  // Requests due, their timeouts, a write that does not drain.
  std::int64_t service(std::int64_t now_ns) override;
  void on_writable() override;
  void on_link_down() override;

 private:
  // Queues `data` and writes what the line takes now; the rest when it becomes writable, within
  // reply_timeout_ms. False with `error` when the line failed.
  bool send(std::string_view data, std::string& error);
  bool flush_output(std::string& error);
  void handle_line(const std::string& line, bool& got_reading);
  static constexpr std::size_t max_read_bytes = 64 * 1024;

  AutocollimatorSettings settings_;
  // The loop thread's:
  std::unique_ptr<serial::SerialLine> line_;
  serial::LineFramer framer_{max_reply_length * 2};
  std::vector<std::string> lines_;
  std::string out_;  // written when the line takes it
  std::int64_t write_deadline_ns_ = 0;
  bool link_closed_ = false;  // a write found the port gone
  int consecutive_timeouts_ = 0;
  bool awaiting_ = false;         // poll: a request is outstanding
  std::int64_t deadline_ns_ = 0;  // poll: reply deadline; stream: silence deadline
  std::int64_t next_poll_ns_ = 0;
  bool after_gap_ = false;
  std::int64_t line_end_ns_ = 0;
};

void register_autocollimator_driver(drivers::DriverRegistry& registry);

}  // namespace guideway::drivers::autocollimator
