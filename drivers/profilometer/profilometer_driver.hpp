#pragma once
// Driver "profilometer-tcp": connects to a profilometer's profile stream (docs/protocols.md),
// assembles traverses and publishes one Sample per point: values x (m), z (m), profile id, point
// index; flags mark the first/last point of a traverse (sample_profile_start/end), over-range
// points and gaps. Loop-driven (drivers/io_loop.hpp): a non-blocking connect (a host name resolved
// off the loop), reads in batches every read_period_us, points stamped with the kernel's receive time
// of the bytes that carried them. Thread safety as drivers::Driver; last_header() from any thread.

#include <chrono>
#include <mutex>
#include <optional>
#include <string>

#include "drivers/driver.hpp"
#include "drivers/io_loop.hpp"
#include "drivers/profilometer/profile_stream.hpp"
#include "drivers/reconnect_backoff.hpp"
#include "drivers/tcp/loop_connector.hpp"
#include "drivers/tcp/tcp_client.hpp"

namespace guideway::drivers::profilometer {

struct ProfilometerConfig {
  std::string host = "127.0.0.1";
  int port = 4001;
  std::chrono::milliseconds connect_timeout{1000};
  std::chrono::milliseconds stall_timeout{2000};  // silence longer than this: the link is lost
  std::chrono::milliseconds backoff_initial{100};
  std::chrono::milliseconds backoff_max{5000};
  // Rest between reads while points stream (0: a wake-up per arrival); what arrives meanwhile is read
  // at once and stamped with the kernel's receive time of the newest segment read.
  std::int64_t read_period_us = drivers::default_read_period_us;
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

  [[nodiscard]] bool loop_driven() const noexcept override { return true; }

 protected:
  void attach(drivers::IoLoop& loop) override;
  void detach() override;

 private:
  enum class Link { connecting, streaming, waiting };
  void begin_connect();
  void connect_failed(const std::string& error);
  void connected(int fd);
  void on_ready(std::uint32_t events);
  void on_timer();
  void on_wake();  // any pass of the loop: a resting reader reads now (the devices share wake-ups)
  // After every device's reads of a pass: a rest that ended with an empty read goes on while another
  // device found data in that pass, else the next bytes wake the driver.
  void on_settle();
  // Reads what is there (at most max_read_bytes per pass: a flooding instrument waits for the others).
  void read_batch(bool opportunistic);
  // Resting (after a read that got bytes): no readiness, a timer at the next read; else the next bytes
  // wake us. Either way the stall timeout.
  void arm_streaming_timer(std::int64_t now);
  void end_connection(const std::string& reason);
  // The back-off after a failed connection or a lost link.
  void wait_backoff();
  void close_socket();
  void publish_events(std::vector<StreamEvent>& events);
  static constexpr std::size_t max_read_bytes = 64 * 1024;

  ProfilometerConfig config_;
  // The loop thread's (attach() to detach()):
  drivers::IoLoop* io_ = nullptr;
  drivers::IoLoop::Id timer_ = 0;
  drivers::IoLoop::Id wake_hook_ = 0;
  drivers::IoLoop::Id settle_hook_ = 0;
  Link link_ = Link::waiting;
  tcp::LoopConnector connector_;
  int fd_ = -1;
  std::int64_t deadline_ns_ = 0;  // waiting: the reconnect
  std::int64_t last_data_ns_ = 0;
  std::int64_t read_at_ns_ = 0;    // streaming: the next read (a future time: resting)
  std::int64_t last_read_ns_ = 0;  // streaming: the last read (the earliest a kernel time can be)
  std::int64_t last_t_ns_ = 0;     // the last time given to bytes (never decreases)
  std::uint64_t served_pass_ = 0;
  bool resting_ = false;      // no readiness interest until read_at_ns_
  bool idle_check_ = false;   // a rest ended with an empty read (on_settle decides)
  bool lonely_ = false;       // a rest ended with nothing read anywhere: wake per arrival
  bool others_pass_ = false;  // since the last bytes, the loop passed by for another device
  drivers::ReconnectBackoff backoff_;
  bool ever_connected_ = false;
  ProfileAssembler assembler_;
  std::vector<StreamEvent> events_;
  std::vector<char> buffer_;
  mutable std::mutex header_mutex_;
  std::optional<ProfileHeader> last_header_;
  std::atomic<std::uint64_t> profiles_{0};
  std::atomic<std::uint64_t> profiles_partial_{0};  // traverses whose END counts points that never arrived whole
  std::atomic<std::uint64_t> points_lost_{0};       // those points
};

void register_profilometer_driver(drivers::DriverRegistry& registry);

}  // namespace guideway::drivers::profilometer
