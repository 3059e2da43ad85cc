#pragma once
// Driver "profilometer-tcp": connects to a profilometer's profile stream (docs/protocols.md),
// assembles traverses and publishes one Sample per point: values x (m), z (m), profile id, point
// index; flags mark the first/last point of a traverse (sample_profile_start/end), over-range
// points and gaps. Thread safety as drivers::Driver; last_header() from any thread.

#include <chrono>
#include <mutex>
#include <optional>
#include <string>

#include "drivers/driver.hpp"
#include "drivers/profilometer/profile_stream.hpp"
#include "drivers/tcp/tcp_client.hpp"

namespace guideway::drivers::profilometer {

struct ProfilometerConfig {
  std::string host = "127.0.0.1";
  int port = 4001;
  std::chrono::milliseconds connect_timeout{1000};
  std::chrono::milliseconds stall_timeout{2000};  // silence longer than this: the link is lost
  std::chrono::milliseconds backoff_initial{100};
  std::chrono::milliseconds backoff_max{5000};
};

ProfilometerConfig parse_profilometer_config(const TableReader& table);

class ProfilometerDriver : public drivers::Driver {
 public:
  ProfilometerDriver(std::string name, ProfilometerConfig config, std::size_t ring_capacity);
  ~ProfilometerDriver() override;
  [[nodiscard]] std::optional<ProfileHeader> last_header() const;
  // Traverses whose END line arrived (partial ones too).
  [[nodiscard]] std::uint64_t profiles_completed() const noexcept { return profiles_.load(); }
  [[nodiscard]] std::vector<drivers::NamedCounter> driver_counters() const override {
    return {{"profiles_completed", profiles_completed()},
            {"profiles_partial", profiles_partial_.load()},
            {"points_lost", points_lost_.load()}};
  }

 protected:
  void run(std::stop_token stop) override;
  void interrupt() override { client_.interrupt(); }

 private:
  void publish_events(std::vector<StreamEvent>& events);

  ProfilometerConfig config_;
  tcp::TcpClient client_;
  mutable std::mutex header_mutex_;
  std::optional<ProfileHeader> last_header_;
  std::atomic<std::uint64_t> profiles_{0};
  std::atomic<std::uint64_t> profiles_partial_{0};  // traverses whose END counts points that never arrived whole
  std::atomic<std::uint64_t> points_lost_{0};       // those points
};

void register_profilometer_driver(drivers::DriverRegistry& registry);

}  // namespace guideway::drivers::profilometer
