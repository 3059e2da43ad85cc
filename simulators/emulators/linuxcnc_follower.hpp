#pragma once
// The virtual machine moved by LinuxCNC (guideway-emulate dbb --follow): instead of tracing its own circles
// it takes every servo period LinuxCNC's HAL streams through guideway-linuxcnc-bridge (drivers/linuxcnc/
// hal_stream.hpp), steps the machine (machine::MotionStepper: servo lag, backlash, spikes, the chain) with
// each joint's command to its drive (motor-pos-cmd less motor-offset: after LinuxCNC's compensation), and
// has the ball bar and the axis encoders read the machine as it moves. The DBB emulator reads them a
// short, steady delay behind the newest period (FollowPlayback), because halsampler hands the periods
// over in bursts. A period the bridge or the stream lost is counted and said on stdout, never hidden;
// between two LinuxCNC runs (a restart with new tables) the machine stands where it stopped.
// Thread safe: the follower's thread writes, the DBB emulator's thread reads (under a mutex).

#include <array>
#include <atomic>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <thread>

#include "simulators/emulators/dbb_emulator.hpp"
#include "simulators/machine/machine.hpp"

namespace guideway::simulators::emulators {

// What the DBB bus reads in one servo period: the bar, then the encoders in bus order (plane axes, normal),
// then the period's number as halsampler counts it (the sample number; served on a fifth node,
// controller_period, so that guidewayd pairs each reading with LinuxCNC's command of the same period).
struct FollowFrame {
  double t_s = 0.0;  // machine time
  std::array<double, 5> bus_m{};
  bool still = false;  // LinuxCNC's command has not moved for FollowSettings::settle_s: the machine stands
};

// The periods played at the pace they come, a delay behind the newest. While the machine moves the
// player's clock runs at wall-clock rate, a little faster or slower (at most 20 %) to hold the delay:
// LinuxCNC's servo thread without a realtime kernel runs late now and then and does not make the periods
// up, so its time drifts from the wall clock's (1 % on this project's loaded machine), and each stall
// spends that much of the delay for good. Where the machine stands still (frames marked still) the pace
// changes nothing the instruments read, so the player takes the delay back there at once: it pauses
// until the delay is whole again, or plays the standstill four times as fast while it is more. The
// delay is 1.5 times the longest wait between two arrivals of the last seconds (halsampler hands the
// periods over in bursts; a loaded PC stalls the link), at least `min_delay_s`. When the periods stop
// coming (LinuxCNC stopped, or stalls longer than the delay while moving) the last one holds; a stall
// counts as an underrun. Not thread safe (the follower locks).
class FollowPlayback {
 public:
  explicit FollowPlayback(double min_delay_s = 0.05) : min_delay_s_(min_delay_s), delay_s_(min_delay_s) {}
  // Frames that arrived together at wall time `wall_s`, oldest first.
  void arrived(double wall_s, const FollowFrame* frames, std::size_t n);
  // The bus at wall time wall_s (interpolated between periods; before the first: false). Calls must come
  // in time order.
  bool at(double wall_s, std::span<double> out);
  [[nodiscard]] double delay_s() const noexcept { return delay_s_; }
  [[nodiscard]] std::uint64_t underruns() const noexcept { return underruns_; }
  // Standing still: how often and how long the player paused to take the delay back, and how much it
  // played fast to shed it (seconds of machine time).
  [[nodiscard]] std::uint64_t pauses() const noexcept { return pauses_; }
  [[nodiscard]] double paused_s() const noexcept { return paused_s_; }
  [[nodiscard]] double skipped_s() const noexcept { return skipped_s_; }
  // LinuxCNC stopped: the last period holds without an underrun.
  void end_of_stream() { ended_ = true; }
  // A new stream (a LinuxCNC restart): its frames' times go on from the last one's; playback starts the
  // delay behind its first arrival.
  void new_stream() {
    ended_ = false;
    playing_ = false;
    last_arrival_s_ = -1.0;
  }

 private:
  double min_delay_s_;
  double delay_s_;
  std::deque<FollowFrame> frames_;
  std::deque<std::pair<double, double>> gaps_;  // (wall second, longest wait between arrivals that second)
  double last_arrival_s_ = -1.0;
  bool playing_ = false;
  double play_s_ = 0.0;  // machine time being played
  double last_wall_s_ = 0.0;
  bool ended_ = false;
  bool starved_ = false;
  std::uint64_t underruns_ = 0;
  bool pausing_ = false;
  std::uint64_t pauses_ = 0;
  double paused_s_ = 0.0, skipped_s_ = 0.0;
  [[nodiscard]] bool still_at(double t_s) const;
};

struct FollowSettings {
  std::string socket_path = "/run/guideway-linuxcnc/bridge.sock";
  machine::Plane plane = machine::Plane::xy;  // the bus order of the encoders
  machine::Vec3 center_m{};                   // where the bar's fixed ball is set (the circle's commanded centre)
  double radius_m = 0.1;
  double height_m = 0.0;
  // The least delay behind LinuxCNC: on a loaded PC (uspace LinuxCNC without a realtime kernel, guidewayd,
  // the emulator) a link that stalls for a tenth of a second holds the machine still, which a session reads
  // as the end of a circle.
  double min_delay_s = 0.3;
  int substeps = 5;  // machine steps per servo period
  // The command standing this long marks the machine still (the servo lag, 30 ms, has settled to e^-16).
  double settle_s = 0.5;
};

class LinuxcncFollower {
 public:
  LinuxcncFollower(const machine::Machine& machine, FollowSettings settings);
  ~LinuxcncFollower();
  LinuxcncFollower(const LinuxcncFollower&) = delete;
  LinuxcncFollower& operator=(const LinuxcncFollower&) = delete;

  void start();
  void stop();
  // The DBB emulator's source: bar length, the plane axes' encoders, the normal axis's.
  [[nodiscard]] DbbSource source();
  [[nodiscard]] std::string status() const;
  [[nodiscard]] std::uint64_t periods() const noexcept { return periods_.load(); }
  [[nodiscard]] std::uint64_t lost() const noexcept { return lost_.load(); }

 private:
  void run(const std::stop_token& stop);
  bool follow_connection(int fd, const std::stop_token& stop);

  machine::Machine machine_;
  FollowSettings settings_;
  std::jthread thread_;
  mutable std::mutex mutex_;
  FollowPlayback playback_;
  std::atomic<std::uint64_t> periods_{0}, lost_{0}, streams_{0}, bad_lines_{0};
  double machine_time_s_ = 0.0;  // the follower thread's: where the next stream's time goes on from
  double last_wall_s_ = 0.0;     // when its last periods arrived
};

}  // namespace guideway::simulators::emulators
