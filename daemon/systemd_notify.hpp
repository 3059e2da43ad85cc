#pragma once
// sd_notify glue: READY/STATUS/STOPPING and the watchdog. Does nothing outside systemd
// (no $NOTIFY_SOCKET), so the daemon runs the same in a terminal.

#include <cstdint>
#include <string>

namespace guideway::daemon {

class SystemdNotifier {
 public:
  SystemdNotifier();
  void ready(const std::string& status);
  void status(const std::string& status);
  void stopping();
  // Pings the watchdog when `progress` moved since the last ping and half the watchdog interval has
  // passed; a stuck pipeline therefore stops the pings and systemd restarts the service.
  void watchdog(std::uint64_t progress, std::int64_t now_mono_ns);
  [[nodiscard]] bool watchdog_enabled() const noexcept { return watchdog_period_ns_ > 0; }
  [[nodiscard]] bool under_systemd() const noexcept { return enabled_; }

 private:
  bool enabled_;
  std::int64_t watchdog_period_ns_ = 0;
  std::int64_t last_ping_ns_ = 0;
  std::uint64_t last_progress_ = 0;
};

}  // namespace guideway::daemon
