// An emulated DBB bus (dbb_emulator.hpp): three CANopen encoder nodes answering or producing SYNC over any can_frame
// fd.
#include "simulators/emulators/dbb_emulator.hpp"

#include <linux/can/error.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/mono_clock.hpp"

namespace guideway::simulators::emulators {

DbbEmulator::DbbEmulator(DbbEmulatorSettings settings, DbbSource source)
    : settings_(std::move(settings)),
      source_(std::move(source)),
      wake_fd_(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK)),
      drop_cycles_(settings_.encoders.size(), 0) {
  for (std::size_t i = 0; i < settings_.encoders.size(); ++i) {
    EncoderNodeSettings n;
    n.scale = settings_.encoders[i];
    if (i < settings_.identities.size()) n.identity = settings_.identities[i];
    n.transmission_type = settings_.transmission_type;
    n.heartbeat_ms = settings_.heartbeat_ms;
    n.auto_start = settings_.nodes_start_operational;
    nodes_.emplace_back(n);
  }
  node_states_.assign(nodes_.size(), drivers::can::NmtState::boot_up);
}

DbbEmulator::~DbbEmulator() {
  stop();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

void DbbEmulator::start(drivers::can::CanSocket listener) {
  if (running_.exchange(true)) return;
  stopped_ = false;
  listener_ = std::move(listener);
  t0_ns_ = mono_now_ns();
  thread_ = std::jthread([this] { loop(); });
}

void DbbEmulator::stop() {
  stopped_ = true;
  if (!running_.exchange(false)) return;
  wake();
  thread_.join();
  close_conn();
  listener_.reset();
}

void DbbEmulator::wake() {
  const std::uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
}

void DbbEmulator::attach(drivers::can::CanSocket fd) {
  if (stopped_.load()) return;  // a stopped emulator hangs up at once (fd closes here)
  {
    std::lock_guard lock(pending_mutex_);
    pending_ = std::move(fd);
    has_pending_ = true;
  }
  wake();
}

void DbbEmulator::inject_disconnect() {
  disconnect_ = true;
  wake();
}
void DbbEmulator::inject_garbage(int frames) { garbage_ += frames; }
void DbbEmulator::inject_truncated(int frames) { truncated_ += frames; }
void DbbEmulator::inject_bad_frames(int frames) { bad_ += frames; }
void DbbEmulator::inject_error_frames(int frames) { error_frames_ += frames; }
void DbbEmulator::inject_bus_off(int restart_ms) {
  bus_off_until_ns_ = mono_now_ns() + static_cast<std::int64_t>(restart_ms) * 1'000'000;
  bus_off_ = true;
}
void DbbEmulator::inject_drop_pdo(std::size_t encoder, int cycles) {
  std::lock_guard lock(drop_mutex_);
  if (encoder < drop_cycles_.size()) drop_cycles_[encoder] += cycles;
}
void DbbEmulator::inject_stall(double seconds) {
  stall_until_ns_ = mono_now_ns() + static_cast<std::int64_t>(seconds * 1e9);
}
void DbbEmulator::inject_burst(int cycles) {
  burst_ += cycles;
  wake();
}

void DbbEmulator::node_command(std::size_t encoder,
                               std::function<void(EncoderNode&, std::int64_t, std::vector<can_frame>&)> f) {
  {
    std::lock_guard lock(node_mutex_);
    node_commands_.push_back([this, encoder, f = std::move(f)](std::int64_t now, std::vector<can_frame>& out) {
      if (encoder < nodes_.size()) f(nodes_[encoder], now, out);
    });
  }
  wake();
}

void DbbEmulator::inject_reboot(std::size_t encoder, double down_s) {
  node_command(encoder, [down_s](EncoderNode& n, std::int64_t now, std::vector<can_frame>&) {
    n.reboot(now, static_cast<std::int64_t>(down_s * 1e9));
  });
}
void DbbEmulator::inject_mute(std::size_t encoder, double seconds) {
  node_command(encoder, [seconds](EncoderNode& n, std::int64_t now, std::vector<can_frame>&) {
    n.mute(now, static_cast<std::int64_t>(seconds * 1e9));
  });
}
void DbbEmulator::inject_sdo_abort(std::size_t encoder, std::uint32_t abort_code) {
  node_command(encoder,
               [abort_code](EncoderNode& n, std::int64_t, std::vector<can_frame>&) { n.set_sdo_abort(abort_code); });
}
void DbbEmulator::inject_identity(std::size_t encoder, EncoderNodeIdentity identity) {
  node_command(encoder, [identity](EncoderNode& n, std::int64_t, std::vector<can_frame>&) {
    EncoderNodeIdentity id = identity;
    if (id.serial_number == 0) id.serial_number = 1000u + n.node_id();
    n.set_identity(id);
  });
}
void DbbEmulator::inject_emcy(std::size_t encoder, std::uint16_t error_code, std::uint8_t error_register) {
  node_command(encoder, [error_code, error_register](EncoderNode& n, std::int64_t, std::vector<can_frame>& out) {
    n.emcy(error_code, error_register, out);
  });
}

std::vector<drivers::can::NmtState> DbbEmulator::node_states() const {
  std::lock_guard lock(node_mutex_);
  return node_states_;
}

void DbbEmulator::run_node_commands(std::int64_t now, std::vector<can_frame>& out) {
  std::vector<std::function<void(std::int64_t, std::vector<can_frame>&)>> commands;
  {
    std::lock_guard lock(node_mutex_);
    commands.swap(node_commands_);
  }
  for (auto& c : commands) c(now, out);
  for (EncoderNode& n : nodes_) n.tick(now, out);
  std::lock_guard lock(node_mutex_);
  for (std::size_t i = 0; i < nodes_.size(); ++i)
    node_states_[i] = nodes_[i].powered() ? nodes_[i].state() : drivers::can::NmtState::boot_up;
}

void DbbEmulator::send_node_frames(std::vector<can_frame>& out) {
  // Frames of nodes nobody hears (no connection) are gone, as on a bus without the driver; a stalled
  // or bus-off bus carries nothing.
  const std::int64_t now = mono_now_ns();
  if (!out.empty() && conn_.valid() && now >= stall_until_ns_.load() && now >= bus_off_until_ns_.load()) {
    std::string err;
    (void)drivers::can::write_can_frames(conn_.fd(), out.data(), out.size(), err);
  }
  out.clear();
}

std::vector<DbbSentCycle> DbbEmulator::log() const {
  std::lock_guard lock(log_mutex_);
  return log_;
}

void DbbEmulator::close_conn() {
  conn_.reset();
  connected_ = false;
}

bool DbbEmulator::send_faults(int fd, std::vector<can_frame>& batch) {
  std::string err;
  auto next = [this] {
    rng_ = rng_ * 1664525u + 1013904223u;
    return rng_ >> 8;
  };
  const std::uint8_t node0 = settings_.encoders.empty() ? 1 : settings_.encoders[0].node_id;
  for (int n = garbage_.exchange(0); n > 0; --n) {
    can_frame f{};
    f.can_id = 0x280 + (next() % 0x100);  // TPDO2/RPDO2 range: never read by the driver
    f.can_dlc = static_cast<std::uint8_t>(next() % 9);
    for (auto& b : f.data) b = static_cast<std::uint8_t>(next());
    batch.push_back(f);
  }
  for (int n = bad_.exchange(0); n > 0; --n) {
    can_frame f = drivers::dbb::make_position_pdo(node0, next());
    f.can_dlc = n % 2 == 0 ? static_cast<std::uint8_t>(5 + next() % 4) : 2;
    batch.push_back(f);
  }
  const auto error_frame = [&](canid_t cls) {
    can_frame f{};
    f.can_id = CAN_ERR_FLAG | cls;
    f.can_dlc = CAN_ERR_DLC;
    batch.push_back(f);
  };
  for (int n = error_frames_.exchange(0); n > 0; --n) error_frame(CAN_ERR_PROT | CAN_ERR_CRTL);
  if (restarted_.exchange(false)) error_frame(CAN_ERR_RESTARTED);
  // Truncated records cannot be batched as can_frames: flush the batch, then write them short.
  const int truncated = truncated_.exchange(0);
  if (truncated > 0) {
    if (!drivers::can::write_can_frames(fd, batch.data(), batch.size(), err)) return false;
    batch.clear();
    for (int n = truncated; n > 0; --n) {
      const can_frame f = drivers::dbb::make_position_pdo(node0, next());
      drivers::can::write_can_record(fd, &f, 1 + next() % (sizeof f - 1), err);
    }
  }
  return true;
}

void DbbEmulator::send_cycle(int fd, int syncs) {
  const std::int64_t now = mono_now_ns();
  std::string err;
  // Bus-off: the error frame, then nothing until the controller restarts, then its notice.
  if (bus_off_.exchange(false)) {
    can_frame f{};
    f.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
    f.can_dlc = CAN_ERR_DLC;
    (void)drivers::can::write_can_frames(fd, &f, 1, err);
    restarted_ = true;
    return;
  }
  if (now < bus_off_until_ns_.load()) return;
  // A cycle goes out as one batch (like a node's TPDOs right after SYNC): SYNC (ours, or the driver's
  // echoed: every one read since the last answer), injected faults, PDOs.
  std::vector<can_frame> batch(static_cast<std::size_t>(syncs), drivers::dbb::make_sync_frame());
  if (!send_faults(fd, batch)) return;
  DbbSentCycle c;
  c.truth_m.assign(settings_.encoders.size(), 0.0);
  c.counts.assign(settings_.encoders.size(), 0);
  // The machine at the time the bus will stamp: a node latches its position at the SYNC and sends within
  // microseconds, and the driver times a cycle by the kernel's stamp of this batch's write. Preempted while
  // the machine was evaluated (a loaded machine, a sanitizer), the values would be milliseconds older than
  // their stamp, an error of the bar's rate of change times the delay that no real bus makes: evaluated
  // again at the new time, at most twice more. Not once the batch went out with truncated records (its
  // SYNC already stamped): its time is the cycle's start.
  constexpr std::int64_t relatch_after_ns = 300'000;
  const bool stamped = batch.empty();
  std::int64_t latched_ns = stamped ? now : mono_now_ns();
  for (int evaluations = 1;; ++evaluations) {
    c.t_s = static_cast<double>(latched_ns - t0_ns_) * 1e-9;
    source_(c.t_s, c.truth_m);
    const std::int64_t after_ns = mono_now_ns();
    if (stamped || after_ns - latched_ns < relatch_after_ns || evaluations == 3) break;
    latched_ns = after_ns;
  }
  c.t_mono_ns = latched_ns;
  {
    std::lock_guard lock(drop_mutex_);
    for (std::size_t i = 0; i < settings_.encoders.size(); ++i) {
      c.counts[i] = drivers::dbb::position_to_count(settings_.encoders[i], c.truth_m[i]);
      nodes_[i].set_count(c.counts[i]);
      if (!nodes_[i].on_sync()) continue;  // not operational, not synchronous, powered off or muted
      if (drop_cycles_[i] > 0) {
        --drop_cycles_[i];
        continue;
      }
      batch.push_back(drivers::dbb::make_position_pdo(settings_.encoders[i].node_id, c.counts[i]));
      c.sent_mask |= 1u << i;
    }
  }
  if (!drivers::can::write_can_frames(fd, batch.data(), batch.size(), err)) return;
  if (c.sent_mask == 0) return;  // no node answered (none operational, or all dropped): no cycle to log
  cycles_.fetch_add(1);
  std::lock_guard lock(log_mutex_);
  log_.push_back(std::move(c));
}

void DbbEmulator::loop() {
  const auto period_ns = static_cast<std::int64_t>(1e9 / settings_.sync_rate_hz);
  std::int64_t next_sync = mono_now_ns() + period_ns;
  std::vector<can_frame> node_out;
  bool powered = false;
  while (running_) {
    {
      std::lock_guard lock(pending_mutex_);
      if (has_pending_) {
        conn_ = std::move(pending_);
        has_pending_ = false;
        connected_ = conn_.valid();
        if (connected_) connections_.fetch_add(1);
      }
    }
    if (disconnect_.exchange(false)) close_conn();
    if (!powered) {  // the nodes power on with the emulator: their boot-up messages reach whoever is connected
      powered = true;
      for (EncoderNode& n : nodes_) n.power_on(mono_now_ns(), node_out);
    }
    run_node_commands(mono_now_ns(), node_out);
    send_node_frames(node_out);
    const std::int64_t now = mono_now_ns();
    const bool stalled = now < stall_until_ns_.load();
    if (conn_.valid() && !stalled) {
      for (int n = burst_.exchange(0); n > 0; --n) send_cycle(conn_.fd(), 1);
      if (settings_.produce_sync && now >= next_sync) {
        send_cycle(conn_.fd(), 1);
        next_sync += period_ns;
        if (next_sync < now) next_sync = now + period_ns;
      }
    }
    // Nanosecond timeout (ppoll): a millisecond poll() would spin for sub-millisecond periods.
    std::int64_t timeout_ns = 50'000'000;
    if (settings_.produce_sync) timeout_ns = std::clamp<std::int64_t>(next_sync - mono_now_ns(), 0, timeout_ns);
    for (const EncoderNode& n : nodes_)
      timeout_ns = std::clamp<std::int64_t>(n.next_deadline() - mono_now_ns(), 0, timeout_ns);
    const timespec ts{0, static_cast<long>(timeout_ns)};
    pollfd fds[3] = {{wake_fd_, POLLIN, 0}, {conn_.fd(), POLLIN, 0}, {listener_.fd(), POLLIN, 0}};
    const int r = ::ppoll(fds, 3, &ts, nullptr);
    if (r <= 0) continue;
    if (fds[0].revents & POLLIN) {
      std::uint64_t v;
      (void)!::read(wake_fd_, &v, sizeof v);
    }
    if (fds[2].revents & POLLIN) {
      const int fd = ::accept4(listener_.fd(), nullptr, nullptr, SOCK_CLOEXEC);
      if (fd >= 0) {
        conn_.reset(fd);  // one client at a time: a new one replaces the old
        connected_ = true;
        connections_.fetch_add(1);
        continue;
      }
    }
    if (conn_.valid() && (fds[1].revents & (POLLIN | POLLHUP | POLLERR))) {
      // Everything queued: NMT and SDO requests go to the nodes; of the SYNCs only the newest is
      // answered (when this thread was held up and several are queued, the older ones are past: a
      // real node never answers a backlog).
      std::string err;
      int syncs_read = 0;
      bool closed = false;
      const std::int64_t t = mono_now_ns();
      for (;;) {
        can_frame f{};
        const auto rr = drivers::can::read_can_frame(conn_.fd(), f, 0, -1, err);
        if (rr == drivers::can::ReadResult::closed || rr == drivers::can::ReadResult::error) {
          closed = true;
          break;
        }
        if (rr == drivers::can::ReadResult::truncated) continue;
        if (rr != drivers::can::ReadResult::frame) break;
        if (drivers::dbb::classify_frame(f).kind == drivers::dbb::FrameInfo::Kind::sync) {
          ++syncs_read;
          continue;
        }
        if (t < stall_until_ns_.load()) continue;  // a stalled bus: nothing answers
        for (EncoderNode& n : nodes_) n.receive(f, t, node_out);
      }
      send_node_frames(node_out);
      if (closed) {
        close_conn();
        continue;
      }
      if (syncs_read > 0 && !settings_.produce_sync && mono_now_ns() >= stall_until_ns_.load()) {
        const std::uint64_t before = cycles_.load();
        // Each SYNC back to its producer where the bus put it, ahead of the answers and in their batch
        // (SocketCAN's CAN_RAW_RECV_OWN_MSGS): what it reads before an echo answered the SYNC before.
        send_cycle(conn_.fd(), syncs_read);
        can_frame next{};
        if (cycles_.load() != before &&
            ::recv(conn_.fd(), &next, sizeof next, MSG_PEEK | MSG_DONTWAIT) == static_cast<ssize_t>(sizeof next) &&
            drivers::dbb::classify_frame(next).kind == drivers::dbb::FrameInfo::Kind::sync) {
          std::lock_guard lock(log_mutex_);
          log_.back().late = true;
        }
      }
    }
  }
}

DbbSource ideal_circle_source(double radius_m, double feed_m_s, int direction, double bar_error_m) {
  return [=](double t_s, std::span<double> out) {
    const double phi = direction * feed_m_s / radius_m * t_s;
    const double a = radius_m * std::cos(phi);
    const double b = radius_m * std::sin(phi);
    if (!out.empty()) out[0] = std::hypot(a, b) + bar_error_m;
    if (out.size() > 1) out[1] = a;
    if (out.size() > 2) out[2] = b;
    for (std::size_t i = 3; i < out.size(); ++i) out[i] = 0.0;
  };
}

}  // namespace guideway::simulators::emulators
