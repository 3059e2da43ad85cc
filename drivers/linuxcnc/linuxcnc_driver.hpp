#pragma once
// linuxcnc-hal: LinuxCNC as a device of guidewayd. It reads guideway-linuxcnc-bridge's stream (hal_stream.hpp)
// and publishes every servo period as a sample of up to five of its columns: by default the joints' commanded
// positions (pos-cmd, m), the program's line and the session pin (docs/linuxcnc.md, "On a real machine").
// A sample's time is its period's: the newest period of a batch at its arrival, each earlier one a servo
// period before the next (halsampler hands them over in bursts). A period the stream lost is skipped in the
// sequence numbers (the pipeline counts it) and counted as lost_periods. LinuxCNC stopped or not started:
// the device waits for the bridge and reconnects (a LinuxCNC restart is a new stream).
// A driver on a thread of its own (poll on the socket and an eventfd).

#include <atomic>
#include <string>
#include <vector>

#include "drivers/driver.hpp"

namespace guideway::drivers::linuxcnc {

struct LinuxcncHalConfig {
  std::string socket = "/run/guideway-linuxcnc/bridge.sock";
  // The stream's columns published, at most max_sample_values; a name ending in _mm is published in m
  // (channel without the suffix), any other as it comes.
  std::vector<std::string> columns = {"x_cmd_mm", "y_cmd_mm", "z_cmd_mm", "program_line", "session"};
};

// The channel name a column gets ("x_cmd_mm" -> "x_cmd") and its unit ("m" or "").
std::string channel_of(const std::string& column);

class LinuxcncHalDriver : public Driver {
 public:
  LinuxcncHalDriver(std::string name, LinuxcncHalConfig config, std::size_t ring_capacity);
  ~LinuxcncHalDriver() override;
  [[nodiscard]] std::vector<NamedCounter> driver_counters() const override;

 protected:
  void run(std::stop_token stop) override;
  void interrupt() override;

 private:
  bool follow(int fd, const std::stop_token& stop);  // false: the stream is not one we can read

  LinuxcncHalConfig config_;
  int wake_fd_ = -1;
  std::atomic<std::uint64_t> periods_{0}, lost_{0}, streams_{0};
};

void register_linuxcnc_driver(DriverRegistry& registry);

}  // namespace guideway::drivers::linuxcnc
