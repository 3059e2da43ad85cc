// sd_notify glue (systemd_notify.hpp): READY, STATUS, STOPPING and the watchdog.
#include "daemon/systemd_notify.hpp"

#include <systemd/sd-daemon.h>

#include <cstdlib>

namespace guideway::daemon {

SystemdNotifier::SystemdNotifier() : enabled_(std::getenv("NOTIFY_SOCKET") != nullptr) {
  std::uint64_t usec = 0;
  if (enabled_ && sd_watchdog_enabled(0, &usec) > 0) watchdog_period_ns_ = static_cast<std::int64_t>(usec) * 1000 / 2;
}

void SystemdNotifier::ready(const std::string& status) {
  if (enabled_) sd_notifyf(0, "READY=1\nSTATUS=%s", status.c_str());
}

void SystemdNotifier::status(const std::string& status) {
  if (enabled_) sd_notifyf(0, "STATUS=%s", status.c_str());
}

void SystemdNotifier::stopping() {
  if (enabled_) sd_notify(0, "STOPPING=1");
}

void SystemdNotifier::watchdog(std::uint64_t progress, std::int64_t now_mono_ns) {
  if (watchdog_period_ns_ <= 0 || now_mono_ns - last_ping_ns_ < watchdog_period_ns_) return;
  if (progress == last_progress_) return;
  last_progress_ = progress;
  last_ping_ns_ = now_mono_ns;
  sd_notify(0, "WATCHDOG=1");
}

}  // namespace guideway::daemon
