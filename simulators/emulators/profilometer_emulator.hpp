#pragma once
// An emulated profilometer (PGI 1240-style) serving the profile stream (docs/protocols.md) on TCP:
// one traverse after another, points paced at a configured rate, with switchable fault injection.
// Thread safe: start/stop from the owning thread; inject/disconnect_for/stall_for/served from any thread.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drivers/profilometer/profile_stream.hpp"

namespace guideway::simulators::emulators {

// One traverse to stream: heights z_m at positions x_m (equal spacing expected); over_range points
// are sent as OVR.
struct EmulatedProfile {
  std::vector<double> x_m;
  std::vector<double> z_m;
  std::vector<bool> over_range;  // empty: none
};
using ProfileSource = std::function<EmulatedProfile(std::uint64_t traverse)>;

// A faced surface without a machine model: feed marks of a round-nosed tool plus a slow waviness.
ProfileSource faced_profile_source(std::size_t points = 1000, double spacing_m = 2e-6, double feed_m = 0.1e-3,
                                   double nose_radius_m = 0.8e-3);

enum class ProfileFault {
  garbage,       // a line of random bytes before the next point
  truncate,      // the next point line cut in half, no newline (it merges with the following line)
  bad_checksum,  // the next point line with a wrong checksum
  burst,         // the next `count` points sent at once, ignoring the pacing
};
std::string_view to_string(ProfileFault f) noexcept;
bool profile_fault_from_string(std::string_view s, ProfileFault& out) noexcept;

// A point the emulator sent intact, with the values a correct parser reads from its line.
struct ServedPoint {
  std::uint64_t profile_id = 0;
  std::uint64_t index = 0;
  double x_m = 0.0;
  double z_m = 0.0;
  bool over_range = false;
};

class ProfilometerEmulator {
 public:
  struct Options {
    ProfileSource source = faced_profile_source();
    double points_per_s = 5000.0;
    double return_s = 0.05;  // pause between traverses (IDLE lines keep the link alive)
    std::string instrument = "guideway-emulate profilometer (PGI 1240-style)";
    std::string stylus = "112/2009-2um";
    double tip_radius_m = 2e-6;
    double z_range_m = 1e-3;
    double speed_m_per_s = 0.5e-3;
  };
  explicit ProfilometerEmulator(Options options);
  ~ProfilometerEmulator();
  ProfilometerEmulator(const ProfilometerEmulator&) = delete;
  ProfilometerEmulator& operator=(const ProfilometerEmulator&) = delete;

  // Listens on host:port (0: any free port); returns the port or -1 with error set.
  int start(const std::string& host, int port, std::string& error);
  void stop();

  void inject(ProfileFault f, int count = 1);
  void disconnect_for(std::chrono::milliseconds d);  // close the connection, refuse new ones for d
  void stall_for(std::chrono::milliseconds d);       // send nothing for d, then go on
  [[nodiscard]] std::vector<ServedPoint> served() const;
  [[nodiscard]] std::uint64_t profiles_sent() const noexcept { return profiles_sent_.load(); }
  [[nodiscard]] std::uint64_t connections() const noexcept { return connections_.load(); }

 private:
  void loop();
  bool listen_now(std::string& error);
  bool serve_client(int fd);
  bool wait_until(std::chrono::steady_clock::time_point t);  // false when stopping or disconnect requested

  Options options_;
  std::string host_;
  int port_ = 0;
  int listen_fd_ = -1;
  std::atomic<bool> running_{false};
  std::thread thread_;
  mutable std::mutex mutex_;
  std::vector<ProfileFault> pending_;
  int burst_left_ = 0;
  std::chrono::steady_clock::time_point down_until_{}, stall_until_{};
  bool drop_ = false;
  std::vector<ServedPoint> served_;
  std::uint64_t next_profile_ = 1;
  std::atomic<std::uint64_t> profiles_sent_{0};
  std::atomic<std::uint64_t> connections_{0};
  std::uint32_t rng_ = 0x2545f491u;
};

// "fault <name> [count]", "disconnect <ms>", "stall <ms>" (guideway-emulate reads them on stdin).
bool apply_profilometer_command(ProfilometerEmulator& emulator, const std::string& line, std::string& message);

}  // namespace guideway::simulators::emulators
