// An emulated TA80-style autocollimator on a pseudo-terminal (autocollimator_emulator.hpp), its readings from a source.
#include "simulators/emulators/autocollimator_emulator.hpp"

#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include "core/mono_clock.hpp"
#include "drivers/serial/serial_port.hpp"

namespace guideway::simulators::emulators {

using drivers::autocollimator::AxisState;
using drivers::autocollimator::Reading;

AutocollimatorEmulator::AutocollimatorEmulator(AutocollimatorEmulatorSettings settings, AutocollimatorSource source)
    : settings_(std::move(settings)), source_(std::move(source)), wake_fd_(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK)) {}

AutocollimatorEmulator::~AutocollimatorEmulator() {
  stop();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

bool AutocollimatorEmulator::open_pty(std::string& error) {
  const int m = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);
  if (m < 0 || ::grantpt(m) < 0 || ::unlockpt(m) < 0) {
    error = std::string("posix_openpt: ") + std::strerror(errno);
    if (m >= 0) ::close(m);
    return false;
  }
  char name[128];
  if (::ptsname_r(m, name, sizeof name) != 0) {
    error = std::string("ptsname: ") + std::strerror(errno);
    ::close(m);
    return false;
  }
  const int s = ::open(name, O_RDWR | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);
  if (s < 0) {
    error = std::string("open ") + name + ": " + std::strerror(errno);
    ::close(m);
    return false;
  }
  termios tio{};
  ::tcgetattr(s, &tio);
  ::cfmakeraw(&tio);  // no echo, no line discipline: the driver sets its own modes again
  ::tcsetattr(s, TCSANOW, &tio);
  master_ = m;
  slave_keep_ = s;
  {
    std::lock_guard lock(path_mutex_);
    pty_path_ = name;
  }
  if (!settings_.link.empty()) {
    const std::string tmp = settings_.link + ".new";
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    std::filesystem::create_symlink(name, tmp, ec);
    if (!ec) std::filesystem::rename(tmp, settings_.link, ec);  // atomic replace
    if (ec) {
      error = "link " + settings_.link + ": " + ec.message();
      return false;
    }
  }
  opens_.fetch_add(1);
  if (on_reopen_) on_reopen_(name);
  return true;
}

void AutocollimatorEmulator::close_pty() {
  // Unplugged, the link goes first (as udev removes /dev/serial/by-id/...): left in place it would
  // name /dev/pts/N after N is freed, and the kernel gives the lowest free N to the next pty opened
  // anywhere, so a driver reconnecting through it would talk to some other program's terminal.
  if (!settings_.link.empty() && master_ >= 0) {
    std::error_code ec;
    if (std::filesystem::read_symlink(settings_.link, ec) == pty_path()) std::filesystem::remove(settings_.link, ec);
  }
  if (master_ >= 0) ::close(master_);
  if (slave_keep_ >= 0) ::close(slave_keep_);
  master_ = slave_keep_ = -1;
  stream_period_ms_ = 0;  // the instrument powers up quiet
}

bool AutocollimatorEmulator::start(std::string& error) {
  if (running_) return true;
  t0_ns_ = mono_now_ns();
  if (!open_pty(error)) return false;
  running_ = true;
  thread_ = std::jthread([this] { loop(); });
  return true;
}

void AutocollimatorEmulator::stop() {
  if (!running_.exchange(false)) return;
  const std::uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
  thread_.join();
  close_pty();
}

std::string AutocollimatorEmulator::pty_path() const {
  std::lock_guard lock(path_mutex_);
  return pty_path_;
}

std::string AutocollimatorEmulator::path() const { return settings_.link.empty() ? pty_path() : settings_.link; }

void AutocollimatorEmulator::on_reopen(std::function<void(const std::string&)> callback) {
  on_reopen_ = std::move(callback);
}

void AutocollimatorEmulator::inject_disconnect(double down_seconds) { disconnect_down_s_ = down_seconds; }
void AutocollimatorEmulator::inject_garbage(int bytes) { garbage_ += bytes; }
void AutocollimatorEmulator::inject_truncated(int lines) { truncated_ += lines; }
void AutocollimatorEmulator::inject_bad_checksum(int lines) { bad_checksum_ += lines; }
void AutocollimatorEmulator::inject_stall(double seconds) {
  stall_until_ns_ = mono_now_ns() + static_cast<std::int64_t>(seconds * 1e9);
}
void AutocollimatorEmulator::inject_burst(int readings) { burst_ += readings; }
void AutocollimatorEmulator::inject_block(double seconds) {
  block_until_ns_ = mono_now_ns() + static_cast<std::int64_t>(seconds * 1e9);
}

bool AutocollimatorEmulator::settle(std::chrono::milliseconds timeout) {
  // The pass under way at the call ends before the next one begins: one more begun is enough.
  const std::uint64_t target = passes_.load() + 1;
  const std::uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);  // no need to sit out the loop's poll timeout
  const std::int64_t deadline = mono_now_ns() + std::chrono::nanoseconds(timeout).count();
  while (passes_.load() < target) {
    if (!running_ || mono_now_ns() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

std::vector<AutocollimatorSentReading> AutocollimatorEmulator::log() const {
  std::lock_guard lock(log_mutex_);
  return log_;
}

void AutocollimatorEmulator::write_raw(const std::string& bytes) {
  std::size_t off = 0;
  int spins = 0;
  while (off < bytes.size() && master_ >= 0) {
    const ssize_t n = ::write(master_, bytes.data() + off, bytes.size() - off);
    if (n > 0) {
      off += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno == EAGAIN && ++spins < 200) {
      pollfd p{master_, POLLOUT, 0};
      ::poll(&p, 1, 5);
      continue;
    }
    return;  // the pty is full (nobody reads): drop, like a UART with no listener
  }
}

void AutocollimatorEmulator::send_faults() {
  auto next = [this] {
    rng_ = rng_ * 1664525u + 1013904223u;
    return rng_ >> 8;
  };
  if (int n = garbage_.exchange(0); n > 0) {
    std::string g;
    for (int i = 0; i < n; ++i) {
      char c = static_cast<char>(next() & 0xFF);
      if (c == '\r' || c == '\n') c = '\x7f';
      g.push_back(c);
    }
    write_raw(g + "\r");
  }
  for (int n = truncated_.exchange(0); n > 0; --n) {
    const std::string full = drivers::autocollimator::format_reply(
        Reading{false, AxisState::valid, AxisState::valid, 12.34, -5.67}, settings_.range_arcsec, settings_.checksum);
    write_raw(full.substr(0, 1 + next() % (full.size() - 2)) + "\r");
  }
  for (int n = bad_checksum_.exchange(0); n > 0; --n) {
    std::string line = drivers::autocollimator::format_reply(
        Reading{false, AxisState::valid, AxisState::valid, 1.5, 2.5}, settings_.range_arcsec, true);
    line[line.size() - 1] = line[line.size() - 1] == '0' ? '1' : '0';  // wrong checksum
    write_raw(line + "\r");
  }
}

void AutocollimatorEmulator::send_reading(bool relative) {
  const double t_s = static_cast<double>(mono_now_ns() - t0_ns_) * 1e-9;
  const AutocollimatorView v = source_(t_s);
  Reading r;
  r.relative = relative;
  r.x_arcsec = v.x_arcsec - (relative ? zero_x_ : 0.0);
  r.y_arcsec = v.y_arcsec - (relative ? zero_y_ : 0.0);
  const bool blocked = mono_now_ns() < block_until_ns_.load();
  r.x_state = r.y_state = v.reflection && !blocked ? AxisState::valid : AxisState::no_reflection;
  const std::string line = drivers::autocollimator::format_reply(r, settings_.range_arcsec, settings_.checksum);
  Reading sent;
  drivers::autocollimator::parse_reply(line, false, sent);  // exactly what went out (rounded, OVER applied)
  write_raw(line + "\r");
  std::lock_guard lock(log_mutex_);
  log_.push_back({t_s, sent});
}

void AutocollimatorEmulator::handle_command(const std::string& line) {
  requests_.fetch_add(1);
  if (mono_now_ns() < stall_until_ns_.load()) return;
  if (line == "a" || line == "r") {
    send_faults();
    send_reading(line == "r");
  } else if (line == "z") {
    const AutocollimatorView v = source_(static_cast<double>(mono_now_ns() - t0_ns_) * 1e-9);
    zero_x_ = v.x_arcsec;
    zero_y_ = v.y_arcsec;
  } else if (line[0] == 'c') {
    long ms = 20;
    if (line.size() > 2) ms = std::strtol(line.c_str() + 2, nullptr, 10);
    stream_period_ms_ = ms > 0 ? ms : 20;
  } else if (line == "s") {
    stream_period_ms_ = 0;
  }
  // Anything else: like the real instruments, unknown requests are ignored.
}

void AutocollimatorEmulator::loop() {
  drivers::serial::LineFramer framer(64);
  std::vector<std::string> lines;
  std::int64_t next_stream = mono_now_ns();
  std::int64_t reopen_at = -1;
  while (running_) {
    passes_.fetch_add(1);
    const std::int64_t now = mono_now_ns();
    if (const double down = disconnect_down_s_.exchange(-1.0); down >= 0) {
      // Unplugged after the last line went through: wait until the reader has taken everything
      // already written, so the tests can demand that nothing delivered is lost (closing the master
      // hangs the slave up and drops what it has not read). Bytes written to the master pass the tty
      // flip buffer (a work queue) before FIONREAD on the slave counts them; a poll() on the slave runs
      // that work first when nothing is readable yet (n_tty_poll), so the count that follows is exact
      // however late a loaded machine runs the queue. (Two empty FIONREADs 5 ms apart were not: under
      // load the queue ran later, a reading was dropped at the close, and the test missed a sample.)
      for (int i = 0; i < 1000 && slave_keep_ >= 0; ++i) {
        pollfd p{slave_keep_, POLLIN, 0};
        (void)::poll(&p, 1, 0);
        int queued = 0;
        if (::ioctl(slave_keep_, FIONREAD, &queued) < 0 || queued == 0) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
      close_pty();
      framer.reset();
      reopen_at = now + static_cast<std::int64_t>(down * 1e9);
    }
    if (reopen_at >= 0 && now >= reopen_at) {
      std::string err;
      if (open_pty(err)) reopen_at = -1;
    }
    const bool stalled = now < stall_until_ns_.load();
    if (master_ >= 0 && !stalled) {
      for (int n = burst_.exchange(0); n > 0; --n) send_reading(false);
      const std::int64_t period = stream_period_ms_.load();
      if (period > 0 && now >= next_stream) {
        send_faults();
        send_reading(false);
        next_stream = std::max(next_stream + period * 1'000'000, now);
      }
    }
    // Nanosecond timeout (ppoll): a millisecond one rounds down to 0 and spins before each reading.
    std::int64_t timeout_ns = 20'000'000;
    if (stream_period_ms_.load() > 0) timeout_ns = std::clamp<std::int64_t>(next_stream - mono_now_ns(), 0, timeout_ns);
    const timespec ts{0, static_cast<long>(timeout_ns)};
    pollfd fds[2] = {{wake_fd_, POLLIN, 0}, {master_, POLLIN, 0}};
    if (::ppoll(fds, 2, &ts, nullptr) <= 0) continue;
    if (fds[0].revents & POLLIN) {
      std::uint64_t v;
      (void)!::read(wake_fd_, &v, sizeof v);
    }
    if (master_ >= 0 && (fds[1].revents & POLLIN)) {
      char buf[256];
      const ssize_t n = ::read(master_, buf, sizeof buf);
      if (n <= 0) continue;
      lines.clear();
      framer.feed(std::string_view(buf, static_cast<std::size_t>(n)), lines);
      for (const auto& l : lines) handle_command(l);
      if (stream_period_ms_.load() > 0 && next_stream < mono_now_ns()) next_stream = mono_now_ns();
    }
  }
}

}  // namespace guideway::simulators::emulators
