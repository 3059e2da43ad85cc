#include "drivers/autocollimator/autocollimator_driver.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/mono_clock.hpp"

namespace guideway::drivers::autocollimator {

AutocollimatorSettings parse_autocollimator_settings(const TableReader& t) {
  AutocollimatorSettings s;
  s.serial.port = t.require_string("port");
  const std::string backend = t.get_choice("backend", "auto", {"auto", "termios", "libserialport"});
  s.serial.backend = backend == "termios"         ? serial::Backend::termios
                     : backend == "libserialport" ? serial::Backend::libserialport
                                                  : serial::Backend::automatic;
  s.serial.baud_rate = static_cast<int>(t.get_int("baud_rate", 9600, 1200, 921600));
  if (!serial::is_supported_baud_rate(s.serial.baud_rate)) {
    t.fail("baud_rate", "unsupported baud rate " + std::to_string(s.serial.baud_rate) +
                            " (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600)");
  }
  if (!serial::parse_framing(t.get_string("framing", "8N1"), s.serial)) {
    t.fail("framing", "expected data bits 5-8, parity N/E/O, stop bits 1-2, e.g. \"8N1\"");
  }
  s.stream = t.get_choice("mode", "poll", {"poll", "stream"}) == "stream";
  s.relative = t.get_choice("reading", "absolute", {"absolute", "relative"}) == "relative";
  s.poll_period_ms = t.get_int("poll_period_ms", 50, 1, 3600000);
  s.stream_period_ms = t.get_int("stream_period_ms", 20, 1, 60000);
  s.reply_timeout_ms = t.get_int("reply_timeout_ms", 300, 1, 600000);
  s.lost_after_timeouts = static_cast<int>(t.get_int("lost_after_timeouts", 3, 1, 1000));
  s.require_checksum = t.get_bool("require_checksum", false);
  s.range_arcsec = t.get_double("range_arcsec", 1000.0, 1.0, max_reported_arcsec);
  s.reconnect_min_ms = t.get_int("reconnect_min_ms", 50, 1, 600000);
  s.reconnect_max_ms = t.get_int("reconnect_max_ms", 5000, s.reconnect_min_ms, 3600000);
  s.x_channel = t.get_string("x_channel", "angle_x");
  s.y_channel = t.get_string("y_channel", "angle_y");
  if (s.x_channel == s.y_channel) t.fail("y_channel", "x_channel and y_channel must differ");
  return s;
}

void reading_to_sample(const Reading& r, double range_arcsec, Sample& s) noexcept {
  s.value_count = 2;
  s.flags = 0;
  const AxisState states[2] = {r.x_state, r.y_state};
  const double values[2] = {r.x_arcsec, r.y_arcsec};
  for (int i = 0; i < 2; ++i) {
    AxisState st = states[i];
    if (st == AxisState::valid && std::fabs(values[i]) > range_arcsec) st = AxisState::out_of_range;
    if (st == AxisState::valid) {
      s.value[i] = values[i] * arcsec_to_rad;
    } else {
      s.value[i] = std::numeric_limits<double>::quiet_NaN();
      s.flags |= st == AxisState::out_of_range ? sample_out_of_range : sample_no_signal;
    }
  }
}

AutocollimatorDriver::AutocollimatorDriver(std::string name, std::size_t ring_capacity, AutocollimatorSettings settings)
    : Driver(std::move(name), "autocollimator-serial", {{settings.x_channel, "rad"}, {settings.y_channel, "rad"}},
             ring_capacity),
      settings_(std::move(settings)),
      wake_fd_(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK)) {}

AutocollimatorDriver::~AutocollimatorDriver() {
  stop();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

void AutocollimatorDriver::interrupt() {
  const std::uint64_t one = 1;
  if (wake_fd_ >= 0) (void)!::write(wake_fd_, &one, sizeof one);
}

void AutocollimatorDriver::handle_line(const std::string& line, bool& got_reading) {
  Reading r;
  if (parse_reply(line, settings_.require_checksum, r) != ParseError::none) {
    bad_frames_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  frames_.fetch_add(1, std::memory_order_relaxed);
  Sample s;
  s.t_mono_ns = line_end_ns_;
  reading_to_sample(r, settings_.range_arcsec, s);
  if (after_gap_) {
    s.flags |= sample_after_gap;
    after_gap_ = false;
  }
  publish(s);
  got_reading = true;
}

std::string AutocollimatorDriver::serve(const std::stop_token& stop, serial::SerialLine& line) {
  serial::LineFramer framer(max_reply_length * 2);
  std::vector<std::string> lines;
  std::string error;
  const std::int64_t timeout_ns = settings_.reply_timeout_ms * 1'000'000;
  const std::int64_t poll_ns = settings_.poll_period_ms * 1'000'000;
  int consecutive_timeouts = 0;
  bool awaiting = false;      // poll: a request is outstanding
  std::int64_t deadline = 0;  // poll: reply deadline; stream: silence deadline
  std::int64_t next_poll = mono_now_ns();
  const std::string request = format_request(settings_.relative ? Request::relative : Request::absolute);

  auto start_stream = [&]() -> bool {
    const auto st = line.write_all(format_request(Request::stream_start, static_cast<int>(settings_.stream_period_ms)),
                                   static_cast<int>(settings_.reply_timeout_ms), error);
    deadline = mono_now_ns() + timeout_ns;
    return st == serial::IoStatus::ok;
  };
  if (settings_.stream && !start_stream()) return "write: " + error;

  auto on_timeout = [&] {
    timeouts_.fetch_add(1, std::memory_order_relaxed);
    if (++consecutive_timeouts >= settings_.lost_after_timeouts) {
      set_state(drivers::DeviceState::lost, "no reply for " + std::to_string(consecutive_timeouts) + " requests");
      after_gap_ = true;
    }
  };

  while (!stop.stop_requested()) {
    std::int64_t now = mono_now_ns();
    if (!settings_.stream) {
      if (awaiting && now >= deadline) {
        awaiting = false;
        on_timeout();
      }
      if (!awaiting && now >= next_poll) {
        const auto st = line.write_all(request, static_cast<int>(settings_.reply_timeout_ms), error);
        if (st == serial::IoStatus::closed) return "port closed";
        if (st != serial::IoStatus::ok) return "write: " + error;
        awaiting = true;
        deadline = now + timeout_ns;
        next_poll = std::max(next_poll + poll_ns, now);  // a late reply never causes a burst of requests
      }
    } else if (now >= deadline) {
      on_timeout();
      if (!start_stream()) return "write: " + error;  // ask again: the instrument may have been reset
    }
    now = mono_now_ns();
    std::int64_t wake_at = deadline;
    if (!settings_.stream && !awaiting) wake_at = next_poll;
    const int wait_ms = static_cast<int>(std::clamp<std::int64_t>((wake_at - now + 999'999) / 1'000'000, 0, 1000));
    const auto w = serial::wait_readable(line, wait_ms, wake_fd_);
    if (w == serial::WaitResult::woken) return {};
    if (w == serial::WaitResult::error) return "poll failed";
    if (w == serial::WaitResult::timeout) continue;
    char buf[512];
    std::size_t got = 0;
    const auto st = line.read_some(buf, sizeof buf, got, error);
    if (st == serial::IoStatus::closed) return "port closed (device gone)";
    if (st == serial::IoStatus::error) return error;
    if (got == 0) continue;
    line_end_ns_ = mono_now_ns();
    lines.clear();
    const std::size_t overflows = framer.feed(std::string_view(buf, got), lines);
    bad_frames_.fetch_add(overflows, std::memory_order_relaxed);
    bool got_reading = false;
    for (const auto& l : lines) handle_line(l, got_reading);
    if (got_reading) {
      if (consecutive_timeouts >= settings_.lost_after_timeouts || consecutive_timeouts > 0) {
        set_state(drivers::DeviceState::streaming);
      }
      consecutive_timeouts = 0;
      awaiting = false;
      if (settings_.stream) deadline = line_end_ns_ + timeout_ns;
    }
  }
  return {};
}

void AutocollimatorDriver::run(std::stop_token stop) {
  std::uint64_t stale = 0;
  (void)!::read(wake_fd_, &stale, sizeof stale);  // a wake-up left over from an earlier stop()
  std::int64_t backoff_ms = settings_.reconnect_min_ms;
  bool connected_once = false;
  while (!stop.stop_requested()) {
    std::string error;
    auto line = serial::open_serial(settings_.serial, error);
    if (!line) {
      set_state(connected_once ? drivers::DeviceState::lost : drivers::DeviceState::error, error);
      if (!sleep_for(stop, std::chrono::milliseconds(backoff_ms))) break;
      backoff_ms = std::min(backoff_ms * 2, settings_.reconnect_max_ms);
      continue;
    }
    if (connected_once) {
      reconnects_.fetch_add(1, std::memory_order_relaxed);
      after_gap_ = true;
    }
    connected_once = true;
    backoff_ms = settings_.reconnect_min_ms;
    set_state(drivers::DeviceState::streaming);
    const std::string why = serve(stop, *line);
    if (settings_.stream) {
      std::string ignored;
      line->write_all(format_request(Request::stream_stop), 100, ignored);
    }
    line.reset();
    if (stop.stop_requested()) break;
    set_state(drivers::DeviceState::lost, why);
    if (!sleep_for(stop, std::chrono::milliseconds(backoff_ms))) break;
  }
}

void register_autocollimator_driver(drivers::DriverRegistry& registry) {
  registry.add("autocollimator-serial",
               "TA80-style two-axis autocollimator, ASCII over a serial line (libserialport; termios for ptys)",
               [](const drivers::DeviceConfig& c) {
                 return std::make_unique<AutocollimatorDriver>(c.name, c.ring_capacity,
                                                               parse_autocollimator_settings(c.table));
               });
}

}  // namespace guideway::drivers::autocollimator
