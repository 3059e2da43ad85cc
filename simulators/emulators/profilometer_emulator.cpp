// An emulated PGI 1240-style profilometer (profilometer_emulator.hpp): the profile stream on TCP, paced, faults
// injected.
#include "simulators/emulators/profilometer_emulator.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <numbers>
#include <sstream>

namespace guideway::simulators::emulators {

namespace {

using Clock = std::chrono::steady_clock;

bool send_all(int fd, const std::string& data) {
  std::size_t off = 0;
  while (off < data.size()) {
    const ssize_t n = ::send(fd, data.data() + off, data.size() - off, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    off += static_cast<std::size_t>(n);
  }
  return true;
}

// The client hung up (FIN or RST): a read would return 0 or fail.
bool peer_closed(int fd) {
  pollfd p{fd, POLLIN, 0};
  if (::poll(&p, 1, 0) <= 0) return false;
  if (p.revents & (POLLHUP | POLLERR)) return true;
  char c;
  const ssize_t n = ::recv(fd, &c, 1, MSG_PEEK | MSG_DONTWAIT);
  return n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK);
}

}  // namespace

ProfileSource faced_profile_source(std::size_t points, double spacing_m, double feed_m, double nose_radius_m) {
  return [=](std::uint64_t traverse) {
    EmulatedProfile p;
    p.x_m.resize(points);
    p.z_m.resize(points);
    const double phase = 0.3 * static_cast<double>(traverse);
    for (std::size_t i = 0; i < points; ++i) {
      const double x = static_cast<double>(i) * spacing_m;
      const double u = std::fmod(x, feed_m) - feed_m / 2;
      p.x_m[i] = x;
      p.z_m[i] = u * u / (2 * nose_radius_m) - feed_m * feed_m / (24 * nose_radius_m) +
                 0.2e-6 * std::sin(2 * std::numbers::pi * x / 0.5e-3 + phase);
    }
    return p;
  };
}

std::string_view to_string(ProfileFault f) noexcept {
  switch (f) {
    case ProfileFault::garbage:
      return "garbage";
    case ProfileFault::truncate:
      return "truncate";
    case ProfileFault::bad_checksum:
      return "bad_checksum";
    case ProfileFault::burst:
      return "burst";
  }
  return "?";
}

bool profile_fault_from_string(std::string_view s, ProfileFault& out) noexcept {
  for (ProfileFault f :
       {ProfileFault::garbage, ProfileFault::truncate, ProfileFault::bad_checksum, ProfileFault::burst}) {
    if (to_string(f) == s) {
      out = f;
      return true;
    }
  }
  return false;
}

ProfilometerEmulator::ProfilometerEmulator(Options options) : options_(std::move(options)) {}

ProfilometerEmulator::~ProfilometerEmulator() { stop(); }

bool ProfilometerEmulator::listen_now(std::string& error) {
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  const int one = 1;
  setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port_));
  if (inet_pton(AF_INET, host_.c_str(), &addr.sin_addr) != 1) {
    error = "not an IPv4 address: " + host_;
  } else if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0 &&
             ::listen(listen_fd_, 4) == 0) {
    socklen_t len = sizeof(addr);
    getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
    return true;
  } else {
    error = host_ + ":" + std::to_string(port_) + ": " + std::strerror(errno);
  }
  ::close(listen_fd_);
  listen_fd_ = -1;
  return false;
}

int ProfilometerEmulator::start(const std::string& host, int port, std::string& error) {
  if (running_) {
    error = "already running";
    return -1;
  }
  host_ = host;
  port_ = port;
  if (!listen_now(error)) return -1;
  running_ = true;
  thread_ = std::thread([this] { loop(); });
  return port_;
}

void ProfilometerEmulator::stop() {
  running_ = false;
  if (thread_.joinable()) thread_.join();
  if (listen_fd_ >= 0) ::close(listen_fd_);
  listen_fd_ = -1;
}

void ProfilometerEmulator::inject(ProfileFault f, int count) {
  std::lock_guard lock(mutex_);
  if (f == ProfileFault::burst) {
    burst_left_ += count;
    return;
  }
  for (int i = 0; i < count; ++i) pending_.push_back(f);
}

void ProfilometerEmulator::disconnect_for(std::chrono::milliseconds d) {
  std::lock_guard lock(mutex_);
  down_until_ = Clock::now() + d;
  drop_ = true;
}

void ProfilometerEmulator::stall_for(std::chrono::milliseconds d) {
  std::lock_guard lock(mutex_);
  stall_until_ = Clock::now() + d;
}

std::vector<ServedPoint> ProfilometerEmulator::served() const {
  std::lock_guard lock(mutex_);
  return served_;
}

bool ProfilometerEmulator::wait_until(Clock::time_point t) {
  while (running_) {
    {
      std::lock_guard lock(mutex_);
      if (drop_) return false;
    }
    const auto now = Clock::now();
    if (now >= t) return true;
    std::this_thread::sleep_for(std::min<Clock::duration>(t - now, std::chrono::milliseconds(5)));
  }
  return false;
}

void ProfilometerEmulator::loop() {
  while (running_) {
    bool drop = false;
    Clock::time_point down_until;
    {
      std::lock_guard lock(mutex_);
      drop = drop_;
      drop_ = false;
      down_until = down_until_;
    }
    if (drop && listen_fd_ >= 0) {
      ::close(listen_fd_);
      listen_fd_ = -1;
    }
    if (Clock::now() < down_until) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      continue;
    }
    std::string error;
    if (listen_fd_ < 0 && !listen_now(error)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      continue;
    }
    pollfd p{listen_fd_, POLLIN, 0};
    if (::poll(&p, 1, 20) <= 0) continue;
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd < 0) continue;
    const int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    connections_.fetch_add(1);
    serve_client(fd);
    ::close(fd);
  }
}

bool ProfilometerEmulator::serve_client(int fd) {
  std::string out = drivers::profilometer::format_banner(options_.instrument);
  std::vector<ServedPoint> unsent;  // served once the bytes are handed to the kernel
  auto flush = [&] {
    if (out.empty()) return true;
    if (peer_closed(fd) || !send_all(fd, out)) return false;
    out.clear();
    std::lock_guard lock(mutex_);
    served_.insert(served_.end(), unsent.begin(), unsent.end());
    unsent.clear();
    return true;
  };
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / options_.points_per_s));
  while (running_) {
    std::uint64_t id;
    {
      std::lock_guard lock(mutex_);
      id = next_profile_++;
    }
    const EmulatedProfile prof = options_.source(id - 1);
    const std::size_t n = std::min(prof.x_m.size(), prof.z_m.size());
    if (n == 0) return false;
    drivers::profilometer::ProfileHeader h;
    h.id = id;
    h.points = n;
    h.length_m = prof.x_m[n - 1] - prof.x_m[0];
    h.spacing_m = n > 1 ? h.length_m / static_cast<double>(n - 1) : 1e-6;
    h.stylus = options_.stylus;
    h.tip_radius_m = options_.tip_radius_m;
    h.z_range_m = options_.z_range_m;
    h.speed_m_per_s = options_.speed_m_per_s;
    out += drivers::profilometer::format_header(h);
    auto next_due = Clock::now();
    bool merged = false;  // the previous line was truncated: this one is glued to it and lost too
    for (std::size_t i = 0; i < n; ++i) {
      std::optional<ProfileFault> fault;
      bool burst = false;
      Clock::time_point stall_until;
      {
        std::lock_guard lock(mutex_);
        if (!pending_.empty()) {
          fault = pending_.front();
          pending_.erase(pending_.begin());
        }
        if (burst_left_ > 0) {
          --burst_left_;
          burst = true;
        }
        stall_until = stall_until_;
      }
      if (Clock::now() < stall_until) {
        if (!flush() || !wait_until(stall_until)) return false;
        next_due = Clock::now();
      }
      if (burst) {
        next_due = Clock::now();
      } else {
        next_due += period;
        if (next_due > Clock::now() + std::chrono::milliseconds(2)) {
          if (!flush() || !wait_until(next_due)) return false;
        }
      }
      const bool ovr = i < prof.over_range.size() && prof.over_range[i];
      std::string line = drivers::profilometer::format_point(i, prof.x_m[i], prof.z_m[i], h, ovr);
      bool intact = !merged;
      merged = false;
      if (fault == ProfileFault::garbage) {
        std::string junk;
        for (int k = 0; k < 40; ++k) {
          rng_ ^= rng_ << 13;
          rng_ ^= rng_ >> 17;
          rng_ ^= rng_ << 5;
          const char c = static_cast<char>(rng_ & 0xff);
          junk += c == '\n' ? '#' : c;
        }
        out += junk + "\n";
      } else if (fault == ProfileFault::truncate) {
        line.resize(line.size() / 2);
        intact = false;
        merged = true;
      } else if (fault == ProfileFault::bad_checksum) {
        line[line.size() - 2] = line[line.size() - 2] == '0' ? '1' : '0';
        intact = false;
      }
      out += line;
      if (intact) {
        // What a correct parser reads from this line: the values the driver must publish.
        const auto parsed = drivers::profilometer::parse_line(std::string_view(line).substr(0, line.size() - 1));
        if (parsed) {
          unsent.push_back({id, i, parsed->x * h.x_scale(), parsed->over_range ? std::nan("") : parsed->z * h.z_scale(),
                            parsed->over_range});
        }
      }
      if (out.size() > 8192 && !flush()) return false;
    }
    out += drivers::profilometer::format_end(id, n);
    if (!flush()) return false;
    profiles_sent_.fetch_add(1);
    // Return stroke: the stylus lifts and travels back; IDLE keeps the link alive.
    const auto back =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options_.return_s));
    while (Clock::now() < back) {
      if (!wait_until(std::min(back, Clock::now() + std::chrono::milliseconds(200)))) return false;
      out += drivers::profilometer::format_idle();
      if (!flush()) return false;
    }
  }
  return true;
}

bool apply_profilometer_command(ProfilometerEmulator& emulator, const std::string& line, std::string& message) {
  std::istringstream in(line);
  std::string word, name;
  in >> word;
  if (word == "fault") {
    int count = 1;
    in >> name;
    if (!(in >> count)) count = 1;
    ProfileFault f{};
    if (!profile_fault_from_string(name, f) || count < 1) {
      message = "unknown fault \"" + name + "\" (garbage, truncate, bad_checksum, burst)";
      return false;
    }
    emulator.inject(f, count);
    message = "ok fault " + name + " " + std::to_string(count);
    return true;
  }
  if (word == "disconnect" || word == "stall") {
    long ms = 0;
    if (!(in >> ms) || ms < 0) {
      message = "usage: " + word + " <ms>";
      return false;
    }
    if (word == "disconnect") {
      emulator.disconnect_for(std::chrono::milliseconds(ms));
    } else {
      emulator.stall_for(std::chrono::milliseconds(ms));
    }
    message = "ok " + word + " " + std::to_string(ms);
    return true;
  }
  message = "unknown command \"" + word + "\" (fault <name> [count], disconnect <ms>, stall <ms>)";
  return false;
}

}  // namespace guideway::simulators::emulators
