#pragma once
// Driver "profilometer-tcp": connects to a profilometer's profile stream (docs/protocols.md),
// assembles traverses and publishes one Sample per point: values x (m), z (m), profile id, point
// index; flags mark the first/last point of a traverse (sample_profile_start/end), over-range
// points and gaps. On the driver skeleton (drivers/loop_driver.hpp): a non-blocking connect (a host
// name resolved off the loop), reads in batches every read_period_us, points stamped with the kernel's
// receive time of the bytes that carried them; `streaming` while points arrive within stall_timeout_ms.
// Thread safety as drivers::Driver; last_header() from any thread.

#include <chrono>
#include <mutex>
#include <optional>
#include <string>

#include "drivers/loop_driver.hpp"
#include "drivers/profilometer/profile_stream.hpp"

namespace guideway::drivers::profilometer {

struct ProfilometerConfig {
  std::string host = "127.0.0.1";
  int port = 4001;
  std::chrono::milliseconds connect_timeout{1000};
  std::chrono::milliseconds stall_timeout{2000};  // silence longer than this: the link is lost
  drivers::Reconnect reconnect{Backoff{0.1, 5.0}, {}};  // reconnect_min_ms 100, reconnect_max_ms 5000
  // Rest between reads while points stream (0: a wake-up per arrival); what arrives meanwhile is read
  // at once and stamped with the kernel's receive time of the newest segment read.
  std::int64_t read_period_us = drivers::default_read_period_us;
  // The most points a second the instrument streams (the stream does not say): what its ring is sized for.
  double points_per_s = 5000.0;
};

ProfilometerConfig parse_profilometer_config(const TableReader& table);

class ProfilometerDriver : public drivers::LoopDriver {
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
  void open() override;
  void on_link_up(std::int64_t now_ns) override;
  // Reads what is there (at most max_read_bytes: a flooding instrument waits for the others).
  drivers::ReadOutcome read_some(bool at_others_pass) override;
  // Rests only while the segments come less than two read periods apart: a stream that comes in
  // bursts further apart (the emulator's, every 2 ms) is read as each arrives, as a slow autocollimator
  // stream is; a rest would only make its points wait (issue 45: the p99 below 1 ms).
  [[nodiscard]] bool rest_after(const drivers::ReadOutcome& read) const override;
  void on_link_down() override;

 private:
  void publish_events(std::vector<StreamEvent>& events);
  static constexpr std::size_t max_read_bytes = 64 * 1024;

  ProfilometerConfig config_;
  // The loop thread's:
  std::int64_t last_read_ns_ = 0;  // the last read (the earliest a kernel time can be)
  std::int64_t last_t_ns_ = 0;     // the last time given to bytes (never decreases)
  std::int64_t arrival_gap_ns_ = 0;  // between the newest segments of the last two reads that took bytes
  ProfileAssembler assembler_;
  std::vector<StreamEvent> events_;
  std::vector<char> buffer_ = std::vector<char>(16384);
  mutable std::mutex header_mutex_;
  std::optional<ProfileHeader> last_header_;
  std::atomic<std::uint64_t> profiles_{0};
  std::atomic<std::uint64_t> profiles_partial_{0};  // traverses whose END counts points that never arrived whole
  std::atomic<std::uint64_t> points_lost_{0};       // those points
};

void register_profilometer_driver(drivers::DriverRegistry& registry);

}  // namespace guideway::drivers::profilometer
