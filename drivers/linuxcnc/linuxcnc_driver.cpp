#include "drivers/linuxcnc/linuxcnc_driver.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/mono_clock.hpp"
#include "drivers/linuxcnc/hal_stream.hpp"

namespace guideway::drivers::linuxcnc {

namespace {

std::vector<ChannelInfo> channels_of(const std::vector<std::string>& columns) {
  std::vector<ChannelInfo> out;
  for (const auto& c : columns) out.push_back({channel_of(c), c.ends_with("_mm") ? "m" : ""});
  return out;
}

int connect_unix(const std::string& path, std::string& error) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof(addr.sun_path)) {
    error = "socket path \"" + path + "\" is empty or too long";
    return -1;
  }
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0 || ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    error = path + ": " + std::strerror(errno) + " (is LinuxCNC running with guideway-bridge.hal?)";
    if (fd >= 0) ::close(fd);
    return -1;
  }
  return fd;
}

}  // namespace

std::string channel_of(const std::string& column) {
  return column.ends_with("_mm") ? column.substr(0, column.size() - 3) : column;
}

LinuxcncHalDriver::LinuxcncHalDriver(std::string name, LinuxcncHalConfig config, std::size_t ring_capacity)
    : Driver(std::move(name), "linuxcnc-hal", channels_of(config.columns), ring_capacity),
      config_(std::move(config)),
      wake_fd_(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK)) {}

LinuxcncHalDriver::~LinuxcncHalDriver() {
  stop();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

std::vector<NamedCounter> LinuxcncHalDriver::driver_counters() const {
  return {{"periods", periods_.load()}, {"lost_periods", lost_.load()}, {"streams", streams_.load()}};
}

void LinuxcncHalDriver::interrupt() {
  const std::uint64_t one = 1;
  [[maybe_unused]] auto ignored = ::write(wake_fd_, &one, sizeof(one));
}

void LinuxcncHalDriver::run(std::stop_token stop) {
  bool first = true;
  while (!stop.stop_requested()) {
    std::string error;
    const int fd = connect_unix(config_.socket, error);
    if (fd < 0) {
      set_state(DeviceState::connecting, error);
      if (!sleep_for(stop, std::chrono::milliseconds(500))) return;
      continue;
    }
    if (!first) ++reconnects_;
    first = false;
    ++streams_;
    const bool readable = follow(fd, stop);
    ::close(fd);
    if (stop.stop_requested()) return;
    if (readable) {
      set_state(DeviceState::lost, "LinuxCNC's stream ended (LinuxCNC stopped?): waiting for the bridge");
    }
    if (!sleep_for(stop, std::chrono::milliseconds(readable ? 200 : 5000))) return;
  }
}

bool LinuxcncHalDriver::follow(int fd, const std::stop_token& stop) {
  std::vector<int> index;  // the published columns' places in the stream
  std::int64_t period_ns = 0;
  std::string refused;
  struct Period {
    std::int64_t seq;
    Sample sample;
  };
  std::vector<Period> batch;
  HalStreamReader reader(
      [&](std::int64_t seq, std::span<const double> v) {
        Period p{seq, {}};
        p.sample.value_count = static_cast<std::uint32_t>(index.size());
        for (std::size_t i = 0; i < index.size(); ++i) {
          const double x = v[static_cast<std::size_t>(index[i])];
          p.sample.value[i] = config_.columns[i].ends_with("_mm") ? x * 1e-3 : x;
        }
        batch.push_back(p);
      },
      [&](std::uint64_t n, std::string_view why) {
        lost_ += n;
        skip_samples(n);
        post_event({"periods_lost", std::to_string(n) + " servo periods lost (" + std::string(why) + ")", true});
      });
  char buf[65536];
  pollfd p[2] = {{fd, POLLIN, 0}, {wake_fd_, POLLIN, 0}};
  while (!stop.stop_requested()) {
    if (::poll(p, 2, 1000) <= 0) continue;
    if (p[1].revents & POLLIN) {
      std::uint64_t junk;
      [[maybe_unused]] auto ignored = ::read(wake_fd_, &junk, sizeof(junk));
      continue;
    }
    const ssize_t n = ::read(fd, buf, sizeof(buf));
    if (n <= 0) return true;
    const std::int64_t arrived = mono_now_ns();
    // The header is complete before the first period is handed over: the columns are found then.
    if (index.empty() && !reader.header_complete()) {
      std::string_view bytes(buf, static_cast<std::size_t>(n));
      const auto end = bytes.find("# end\n");
      reader.feed(end == std::string_view::npos ? bytes : bytes.substr(0, end + 6));
      if (!reader.header_complete()) {
        if (!reader.error().empty()) break;
        continue;
      }
      for (const auto& c : config_.columns) {
        const int i = reader.header().column(c);
        if (i < 0) refused += (refused.empty() ? "" : ", ") + c;
        index.push_back(i);
      }
      if (!refused.empty()) break;
      period_ns = reader.header().period_ns;
      set_state(DeviceState::streaming);
      if (end != std::string_view::npos) reader.feed(bytes.substr(end + 6));
    } else {
      reader.feed(std::string_view(buf, static_cast<std::size_t>(n)));
    }
    if (!reader.error().empty()) break;
    bad_frames_ = reader.counters().bad_lines;
    // Each period's time: the newest one's at its arrival, the others a servo period apart.
    for (const Period& q : batch) {
      Sample s = q.sample;
      s.t_mono_ns = arrived - seq_step(q.seq, batch.back().seq) * period_ns;
      publish(s);
      ++frames_;
      ++periods_;
    }
    batch.clear();
  }
  if (!refused.empty()) {
    set_state(DeviceState::error, "the bridge's stream has no column " + refused + " (it has: " +
                                      [&] {
                                        std::string all;
                                        for (const auto& c : reader.header().columns) all += (all.empty() ? "" : ",") + c;
                                        return all;
                                      }() +
                                      ")");
    return false;
  }
  if (!reader.error().empty()) {
    set_state(DeviceState::error, "not the bridge's stream: " + reader.error());
    return false;
  }
  return true;
}

void register_linuxcnc_driver(DriverRegistry& registry) {
  registry.add("linuxcnc-hal",
               "LinuxCNC's servo periods from guideway-linuxcnc-bridge (sampler + halsampler): commanded positions "
               "and the program's state",
               [](const DeviceConfig& c) -> std::unique_ptr<Driver> {
                 LinuxcncHalConfig cfg;
                 cfg.socket = c.table.get_string("socket", cfg.socket);
                 cfg.columns = c.table.get_strings("columns", cfg.columns);
                 if (cfg.columns.empty() || cfg.columns.size() > max_sample_values)
                   c.table.fail("columns", "give 1 to " + std::to_string(max_sample_values) + " of the stream's columns");
                 return std::make_unique<LinuxcncHalDriver>(c.name, cfg, c.ring_capacity);
               });
}

}  // namespace guideway::drivers::linuxcnc
