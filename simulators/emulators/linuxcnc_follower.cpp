// The virtual machine moved by LinuxCNC (linuxcnc_follower.hpp): every servo period of the bridge's stream played on
// the machine.
#include "simulators/emulators/linuxcnc_follower.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <sstream>

#include "core/mono_clock.hpp"
#include "core/number_format.hpp"
#include "drivers/linuxcnc/hal_stream.hpp"
#include "simulators/emulators/can_serial_machine_sources.hpp"

namespace guideway::simulators::emulators {

namespace {

constexpr double window_s = 10.0;

double wall_now_s() { return static_cast<double>(mono_now_ns()) * 1e-9; }

// Keeps per wall-clock second the least (or largest) value, for the last window_s seconds.
void windowed(std::deque<std::pair<double, double>>& w, double wall_s, double value, bool keep_least) {
  const double second = std::floor(wall_s);
  if (!w.empty() && w.back().first == second) {
    w.back().second = keep_least ? std::min(w.back().second, value) : std::max(w.back().second, value);
  } else {
    w.emplace_back(second, value);
  }
  while (!w.empty() && w.front().first < second - window_s) w.pop_front();
}

double window_extreme(const std::deque<std::pair<double, double>>& w, bool least) {
  double out = w.front().second;
  for (const auto& [s, v] : w) out = least ? std::min(out, v) : std::max(out, v);
  return out;
}

int connect_unix(const std::string& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof(addr.sun_path)) return -1;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

void say(const std::string& line) {
  std::printf("follow: %s\n", line.c_str());
  std::fflush(stdout);
}

}  // namespace

void FollowPlayback::arrived(double wall_s, const FollowFrame* frames, std::size_t n) {
  if (n == 0) return;
  frames_.insert(frames_.end(), frames, frames + n);
  if (last_arrival_s_ >= 0) {
    windowed(gaps_, wall_s, wall_s - last_arrival_s_, false);
    // The delay grows at once with a long wait and shrinks only as the window forgets it.
    delay_s_ = std::max(min_delay_s_, 1.5 * window_extreme(gaps_, false));
  }
  last_arrival_s_ = wall_s;
}

bool FollowPlayback::at(double wall_s, std::span<double> out) {
  if (frames_.empty()) return false;
  const FollowFrame& newest = frames_.back();
  if (!playing_) {
    play_s_ = std::max(play_s_, std::max(frames_.front().t_s, newest.t_s - delay_s_));
    playing_ = true;
  } else {
    const double dt = std::max(0.0, wall_s - last_wall_s_);
    const double depth = newest.t_s - play_s_;
    if (!ended_ && still_at(play_s_)) {
      // Standing still: pause while the delay is short (a stall spent it), play fast while it is long,
      // never fast into the motion that follows.
      if (depth < (pausing_ ? 1.0 : 0.9) * delay_s_) {  // not for the jitter of the arrivals
        if (!pausing_) ++pauses_;
        pausing_ = true;
        paused_s_ += dt;
      } else {
        pausing_ = false;
        const double fast = play_s_ + 4.0 * dt;
        const bool shed = depth > delay_s_ + 4.0 * dt && still_at(fast);
        if (shed) skipped_s_ += 3.0 * dt;
        play_s_ = shed ? fast : play_s_ + dt;
      }
    } else {
      // Faster when the buffer is deeper than the delay, slower when shallower: the drift is taken up.
      pausing_ = false;
      const double rate = std::clamp(1.0 + 0.25 * (depth - delay_s_) / delay_s_, 0.8, 1.2);
      play_s_ += dt * rate;
    }
  }
  last_wall_s_ = wall_s;
  const auto copy = [&](const FollowFrame& f) {
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = i < f.bus_m.size() ? f.bus_m[i] : 0.0;
  };
  if (play_s_ >= newest.t_s) {
    if (!ended_ && !starved_ && play_s_ > newest.t_s + 1e-3) {
      ++underruns_;
      starved_ = true;
    }
    play_s_ = newest.t_s;  // resumes from here once periods come again
    copy(newest);
    return true;
  }
  starved_ = false;
  if (play_s_ <= frames_.front().t_s) {
    copy(frames_.front());
  } else {
    const auto hi = std::lower_bound(frames_.begin(), frames_.end(), play_s_,
                                     [](const FollowFrame& f, double t) { return f.t_s < t; });
    const auto lo = hi - 1;
    const double w = (play_s_ - lo->t_s) / (hi->t_s - lo->t_s);
    for (std::size_t i = 0; i < out.size(); ++i)
      out[i] = i < lo->bus_m.size() ? lo->bus_m[i] + w * (hi->bus_m[i] - lo->bus_m[i]) : 0.0;
  }
  while (frames_.size() > 2 && frames_[1].t_s < play_s_ - 1.0) frames_.pop_front();
  return true;
}

bool FollowPlayback::still_at(double t_s) const {
  // The frames either side of t_s (the one at it, the one before).
  const auto hi =
      std::lower_bound(frames_.begin(), frames_.end(), t_s, [](const FollowFrame& f, double t) { return f.t_s < t; });
  if (hi == frames_.end()) return false;
  return hi->still && (hi == frames_.begin() || (hi - 1)->still);
}

LinuxcncFollower::LinuxcncFollower(const machine::Machine& machine, FollowSettings settings)
    : machine_(machine), settings_(std::move(settings)), playback_(settings_.min_delay_s) {}

LinuxcncFollower::~LinuxcncFollower() { stop(); }

void LinuxcncFollower::start() {
  thread_ = std::jthread([this](const std::stop_token& st) { run(st); });
}

void LinuxcncFollower::stop() {
  if (thread_.joinable()) {
    thread_.request_stop();
    thread_.join();
  }
}

DbbSource LinuxcncFollower::source() {
  return [this](double /*t_s*/, std::span<double> out) {
    std::lock_guard lock(mutex_);
    if (!playback_.at(wall_now_s(), out)) {
      // Before LinuxCNC's first period: the machine at rest where the bar is set.
      std::fill(out.begin(), out.end(), 0.0);
    }
  };
}

std::string LinuxcncFollower::status() const {
  std::ostringstream o;
  double delay = 0;
  std::uint64_t underruns = 0, pauses = 0;
  double paused = 0, skipped = 0;
  {
    std::lock_guard lock(mutex_);
    delay = playback_.delay_s();
    underruns = playback_.underruns();
    pauses = playback_.pauses();
    paused = playback_.paused_s();
    skipped = playback_.skipped_s();
  }
  o << "following LinuxCNC: " << streams_.load() << " streams, " << periods_.load() << " periods, " << lost_.load()
    << " lost, " << bad_lines_.load() << " bad lines, playback " << std::lround(delay * 1e3) << " ms behind, "
    << underruns << " underruns, " << pauses << " pauses standing still (" << printf_number("%.1f", paused)
    << " s) to take the delay back, " << printf_number("%.1f", skipped) << " s of standstill skipped";
  return o.str();
}

void LinuxcncFollower::run(const std::stop_token& stop) {
  bool said_waiting = false;
  while (!stop.stop_requested()) {
    const int fd = connect_unix(settings_.socket_path);
    if (fd < 0) {
      if (!said_waiting) say("waiting for guideway-linuxcnc-bridge at " + settings_.socket_path);
      said_waiting = true;
      for (int i = 0; i < 10 && !stop.stop_requested(); ++i) ::usleep(20000);
      continue;
    }
    said_waiting = false;
    const std::uint64_t stream = ++streams_;
    say("stream " + std::to_string(stream) + ": connected to " + settings_.socket_path);
    const bool ok = follow_connection(fd, stop);
    ::close(fd);
    {
      std::lock_guard lock(mutex_);
      playback_.end_of_stream();
    }
    say("stream " + std::to_string(stream) + " ended" + (ok ? "" : " (refused)") + ": " + status());
    if (!ok)
      for (int i = 0; i < 100 && !stop.stop_requested(); ++i) ::usleep(20000);
  }
}

namespace {

// The period's columns the machine needs, found in the stream's header.
struct Columns {
  std::array<int, 3> motor{}, offset{}, command{};
  bool find(const drivers::linuxcnc::HalStreamHeader& h, std::string& missing) {
    const char* axes = "xyz";
    for (std::size_t j = 0; j < 3; ++j) {
      const std::string a(1, axes[j]);
      motor[j] = h.column(a + "_motor_mm");
      offset[j] = h.column(a + "_motor_offset_mm");
      command[j] = h.column(a + "_cmd_mm");
      if (motor[j] < 0) missing += " " + a + "_motor_mm";
    }
    return missing.empty();
  }
};

double column_m(std::span<const double> v, int i) { return i >= 0 ? v[static_cast<std::size_t>(i)] * 1e-3 : 0.0; }

}  // namespace

bool LinuxcncFollower::follow_connection(int fd, const std::stop_token& stop) {
  const auto& cfg = machine_.config();
  const auto bus = bus_axes(settings_.plane);
  const double nominal = std::hypot(settings_.radius_m, settings_.height_m);
  machine::DbbBar bar(cfg, machine::dbb_fixed_ball(cfg, settings_.center_m, settings_.plane, settings_.height_m),
                      nominal, cfg.noise.seed + streams_.load());
  std::unique_ptr<machine::MotionStepper> stepper;
  Columns columns;
  bool columns_ok = false;
  double period_s = 0, t_rel = 0, t0 = 0;
  std::int64_t last_seq = 0;
  machine::Vec3 last_motor{};
  double standing_s = 0;  // how long the command has not moved
  std::vector<FollowFrame> batch;
  bool refused = false;
  const drivers::linuxcnc::HalStreamReader* reader_ptr = nullptr;
  const auto reader_header = [&]() -> const drivers::linuxcnc::HalStreamHeader& { return reader_ptr->header(); };
  drivers::linuxcnc::HalStreamReader reader(
      [&](std::int64_t seq, std::span<const double> v) {
        if (refused) return;
        if (!columns_ok) {
          std::string missing;
          if (!columns.find(reader_header(), missing)) {
            say("the bridge's stream has no column" + missing + ": the virtual machine cannot follow it");
            refused = true;
            return;
          }
          columns_ok = true;
          period_s = static_cast<double>(reader_header().period_ns) * 1e-9;
        }
        machine::Vec3 motor{}, cmd{};
        for (std::size_t j = 0; j < 3; ++j) {
          motor[j] = column_m(v, columns.motor[j]) - column_m(v, columns.offset[j]);
          cmd[j] = columns.command[j] >= 0 ? column_m(v, columns.command[j]) : motor[j];
        }
        if (!stepper) {
          // A new stream goes on in machine time from where the last one stopped, the pause included.
          t0 = machine_time_s_ + (last_wall_s_ > 0 ? std::max(0.0, wall_now_s() - last_wall_s_) : 0.0);
          stepper = std::make_unique<machine::MotionStepper>(machine_, motor, t0, cfg.noise.seed + streams_.load());
        } else {
          // Periods the stream lost are crossed as one ramp: the drive's command went there somehow.
          const double span = static_cast<double>(drivers::linuxcnc::seq_step(last_seq, seq)) * period_s;
          const double dt = span / settings_.substeps;
          for (int q = 1; q <= settings_.substeps; ++q) {
            machine::Vec3 m{};
            for (std::size_t j = 0; j < 3; ++j) m[j] = last_motor[j] + (motor[j] - last_motor[j]) * q / settings_.substeps;
            stepper->step(m, t_rel + q * dt, dt);
          }
          t_rel += span;
          standing_s = motor == last_motor ? standing_s + span : 0.0;
        }
        last_seq = seq;
        last_motor = motor;
        const machine::MotionSample s = stepper->sample(cmd, t_rel);
        FollowFrame f;
        f.t_s = t0 + t_rel;
        f.still = standing_s >= settings_.settle_s;
        f.bus_m = {bar.read(s.tool, f.t_s), s.encoder[static_cast<std::size_t>(bus[0])],
                   s.encoder[static_cast<std::size_t>(bus[1])], s.encoder[static_cast<std::size_t>(bus[2])],
                   static_cast<double>(seq)};
        batch.push_back(f);
        ++periods_;
      },
      [&](std::uint64_t n, std::string_view why) {
        lost_ += n;
        say("lost " + std::to_string(n) + " servo periods (" + std::string(why) + ")");
      });
  reader_ptr = &reader;
  char buf[65536];
  bool new_stream = true;
  while (!stop.stop_requested()) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 200) <= 0) continue;
    const ssize_t n = ::read(fd, buf, sizeof(buf));
    if (n <= 0) break;
    reader.feed(std::string_view(buf, static_cast<std::size_t>(n)));
    if (!reader.error().empty()) {
      say("the bridge's stream: " + reader.error());
      refused = true;
    }
    if (refused) break;
    bad_lines_ = reader.counters().bad_lines;
    if (batch.empty()) continue;
    std::lock_guard lock(mutex_);
    if (new_stream) playback_.new_stream();
    new_stream = false;
    playback_.arrived(wall_now_s(), batch.data(), batch.size());
    machine_time_s_ = batch.back().t_s;
    last_wall_s_ = wall_now_s();
    batch.clear();
  }
  return !refused;
}

}  // namespace guideway::simulators::emulators
