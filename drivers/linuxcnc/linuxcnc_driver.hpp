#pragma once
// linuxcnc-hal: LinuxCNC as a device of guidewayd. It reads guideway-linuxcnc-bridge's stream (hal_stream.hpp)
// and publishes every servo period as a sample of up to five of its columns: by default the joints' commanded
// positions (pos-cmd, m), the program's line and the session pin (docs/linuxcnc.md, "On a real machine").
// A sample's time is its period's: the newest period of a batch at its arrival, each earlier one a servo
// period before the next (halsampler hands them over in bursts). A period the stream lost is skipped in the
// sequence numbers (the pipeline counts it) and counted as lost_periods. LinuxCNC stopped or not started:
// the device waits for the bridge and reconnects (a LinuxCNC restart is a new stream).
// A loop-driven driver (drivers/loop_driver.hpp): it reads every arrival at once (halsampler's bursts are
// already batched), and a LinuxCNC that stalls for seconds is no silence that ends the link.

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "drivers/linuxcnc/hal_stream.hpp"
#include "drivers/loop_driver.hpp"

namespace guideway::drivers::linuxcnc {

struct LinuxcncHalConfig {
  std::string socket = "/run/guideway-linuxcnc/bridge.sock";
  // The stream's columns published, at most max_sample_values; a name ending in _mm is published in m
  // (channel without the suffix), any other as it comes. "period" is the period's number (halsampler's
  // sample number): a virtual machine that carries it lets a DBB session pair each reading with the command
  // of the same period (sessions/dbb_session.cpp).
  std::vector<std::string> columns = {"x_cmd_mm", "y_cmd_mm", "z_cmd_mm", "session", "period"};
};

// The channel name a column gets ("x_cmd_mm" -> "x_cmd") and its unit ("m" or "").
std::string channel_of(const std::string& column);

class LinuxcncHalDriver : public drivers::LoopDriver {
 public:
  LinuxcncHalDriver(std::string name, LinuxcncHalConfig config, std::size_t ring_capacity);
  ~LinuxcncHalDriver() override;
  [[nodiscard]] std::vector<NamedCounter> driver_counters() const override;

 protected:
  void open() override;
  void on_link_up(std::int64_t now_ns) override;
  ReadOutcome read_some(bool at_others_pass) override;
  void on_link_down() override;

 private:
  // The header's columns found (index_) once it is complete; false with the device's error when the
  // stream is not the bridge's or lacks a column.
  bool take_header();
  void publish_batch(std::int64_t arrived_ns);
  static constexpr std::size_t max_read_bytes = 256 * 1024;

  LinuxcncHalConfig config_;
  // The loop thread's:
  int fd_ = -1;
  std::unique_ptr<HalStreamReader> reader_;
  std::vector<int> index_;  // the published columns' places in the stream (period_column: the period's number)
  static constexpr int period_column = -2;
  std::int64_t period_ns_ = 0;
  struct Period {
    std::int64_t seq;
    Sample sample;
  };
  std::vector<Period> batch_;
  std::vector<char> buffer_ = std::vector<char>(65536);
  std::atomic<std::uint64_t> periods_{0}, lost_{0}, streams_{0};
};

void register_linuxcnc_driver(DriverRegistry& registry);

}  // namespace guideway::drivers::linuxcnc
