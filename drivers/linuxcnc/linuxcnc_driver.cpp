// "linuxcnc-hal" (linuxcnc_driver.hpp): LinuxCNC as a device, every servo period of the bridge's stream one sample.
#include "drivers/linuxcnc/linuxcnc_driver.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/mono_clock.hpp"
#include "drivers/linuxcnc/hal_stream.hpp"
#include "drivers/tcp/tcp_client.hpp"

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
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
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

namespace {

LoopPolicy linuxcnc_policy() {
  LoopPolicy p;
  p.reconnect.backoff = Backoff{0.2, 5.0};  // LinuxCNC (re)started: the bridge is back within its first waits
  p.schedule = ReadSchedule::per_arrival;
  p.read_period_ns = 0;
  return p;
}

}  // namespace

LinuxcncHalDriver::LinuxcncHalDriver(std::string name, LinuxcncHalConfig config, std::size_t ring_capacity)
    : LoopDriver(std::move(name), "linuxcnc-hal", channels_of(config.columns), ring_capacity, linuxcnc_policy()),
      config_(std::move(config)) {}

LinuxcncHalDriver::~LinuxcncHalDriver() { stop(); }

std::vector<NamedCounter> LinuxcncHalDriver::driver_counters() const {
  return {{"periods", periods_.load()}, {"lost_periods", lost_.load()}, {"streams", streams_.load()}};
}

void LinuxcncHalDriver::open() {
  std::string error;
  fd_ = connect_unix(config_.socket, error);
  if (fd_ < 0) {
    link_failed(error);
    return;
  }
  link_up(fd_);
}

void LinuxcncHalDriver::on_link_up(std::int64_t) {
  streams_.fetch_add(1, std::memory_order_relaxed);
  index_.clear();
  batch_.clear();
  period_ns_ = 0;
  reader_ = std::make_unique<HalStreamReader>(
      [this](std::int64_t seq, std::span<const double> v) {
        Period p{seq, {}};
        p.sample.value_count = static_cast<std::uint32_t>(index_.size());
        for (std::size_t i = 0; i < index_.size(); ++i) {
          const double x =
              index_[i] == period_column ? static_cast<double>(seq) : v[static_cast<std::size_t>(index_[i])];
          p.sample.value[i] = config_.columns[i].ends_with("_mm") ? x * 1e-3 : x;
        }
        batch_.push_back(p);
      },
      [this](std::uint64_t n, std::string_view why) {
        lost_.fetch_add(n, std::memory_order_relaxed);
        skip_samples(n);
        post_event({"periods_lost", std::to_string(n) + " servo periods lost (" + std::string(why) + ")", true});
      });
}

void LinuxcncHalDriver::on_link_down() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  reader_.reset();
  batch_.clear();
}

bool LinuxcncHalDriver::take_header() {
  std::string refused;
  for (const auto& c : config_.columns) {
    const int i = c == "period" ? period_column : reader_->header().column(c);
    if (i < 0 && i != period_column) refused += (refused.empty() ? "" : ", ") + c;
    index_.push_back(i);
  }
  if (refused.empty()) {
    period_ns_ = reader_->header().period_ns;
    return true;
  }
  std::string all;
  for (const auto& c : reader_->header().columns) all += (all.empty() ? "" : ",") + c;
  const std::string why = "the bridge's stream has no column " + refused + " (it has: " + all + ")";
  end_link(why);
  set_state(DeviceState::error, why);
  return false;
}

void LinuxcncHalDriver::publish_batch(std::int64_t arrived_ns) {
  // Each period's time: the newest one's at its arrival, the others a servo period apart.
  for (const Period& q : batch_) {
    Sample s = q.sample;
    s.t_mono_ns = arrived_ns - seq_step(q.seq, batch_.back().seq) * period_ns_;
    publish(s);
    frames_.fetch_add(1, std::memory_order_relaxed);
    periods_.fetch_add(1, std::memory_order_relaxed);
  }
  batch_.clear();
}

ReadOutcome LinuxcncHalDriver::read_some(bool) {
  ReadOutcome out;
  while (link_is_up()) {
    if (out.taken >= max_read_bytes) {  // a burst larger than this: the other devices first, then on
      out.more = true;
      break;
    }
    const tcp::ReadResult r = tcp::read_some(fd_, buffer_.data(), buffer_.size());
    if (r.status == tcp::ReadStatus::would_block) break;
    if (r.status != tcp::ReadStatus::data) {
      out.ended = r.status == tcp::ReadStatus::closed
                      ? "LinuxCNC's stream ended (LinuxCNC stopped?): waiting for the bridge"
                      : "LinuxCNC's stream: " + r.message;
      break;
    }
    const std::size_t n = r.bytes;
    out.taken += n;
    const std::int64_t arrived = mono_now_ns();
    std::string_view bytes(buffer_.data(), n);
    // The header is complete before the first period is handed over: the columns are found then.
    if (!reader_->header_complete()) {
      const auto end = bytes.find("# end\n");
      reader_->feed(end == std::string_view::npos ? bytes : bytes.substr(0, end + 6));
      if (reader_->header_complete() && !take_header()) return out;
      bytes = end == std::string_view::npos ? std::string_view() : bytes.substr(end + 6);
    }
    if (!bytes.empty()) reader_->feed(bytes);
    if (!reader_->error().empty()) {
      const std::string why = "not the bridge's stream: " + reader_->error();
      end_link(why);
      set_state(DeviceState::error, why);
      return out;
    }
    bad_frames_.store(reader_->counters().bad_lines, std::memory_order_relaxed);
    publish_batch(arrived);
    if (n < buffer_.size()) break;  // the socket is empty (or nearly)
  }
  return out;
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
                 // A sample per servo period: LinuxCNC's servo thread runs at 1 kHz unless its configuration
                 // says otherwise, and the stream tells its period only once connected (faster: ring_capacity).
                 constexpr double servo_rate_hz = 1000.0;
                 return std::make_unique<LinuxcncHalDriver>(c.name, cfg, c.ring_for(servo_rate_hz));
               });
}

}  // namespace guideway::drivers::linuxcnc
