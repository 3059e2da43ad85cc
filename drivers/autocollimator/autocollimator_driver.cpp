// "autocollimator-serial" (autocollimator_driver.hpp): a TA80-style autocollimator polled or streaming on a serial
// line.
#include "drivers/autocollimator/autocollimator_driver.hpp"

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
  s.reconnect = drivers::read_reconnect(t, std::chrono::milliseconds(50), std::chrono::milliseconds(5000));
  s.x_channel = t.get_string("x_channel", "angle_x");
  s.y_channel = t.get_string("y_channel", "angle_y");
  if (s.x_channel == s.y_channel) t.fail("y_channel", "x_channel and y_channel must differ");
  s.read_period_us = t.get_int("read_period_us", drivers::default_read_period_us, 0, 100'000);
  if (s.read_period_us * 1000 >= s.reply_timeout_ms * 1'000'000)
    t.fail("read_period_us", "must be shorter than reply_timeout_ms (" + std::to_string(s.reply_timeout_ms) + " ms)");
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

namespace {

drivers::LoopPolicy policy_of(const AutocollimatorSettings& s) {
  drivers::LoopPolicy p;
  p.reconnect = s.reconnect;
  p.unreached_is_error = true;  // a port that was never there is a wrong path
  // Stream mode with lines less than two read periods apart rests between reads; otherwise (polls,
  // slow streams) a rest would only delay the line.
  const bool rests = s.stream && s.read_period_us > 0 && s.stream_period_ms * 1000 < 2 * s.read_period_us;
  p.schedule = rests ? drivers::ReadSchedule::rest : drivers::ReadSchedule::per_arrival;
  p.read_period_ns = s.read_period_us * 1000;
  // Lost after lost_after_timeouts requests (or stream periods) without a reading.
  const std::int64_t period_ms = s.stream ? s.stream_period_ms : s.poll_period_ms;
  p.sample_bound_ns = s.lost_after_timeouts * (s.reply_timeout_ms + period_ms) * 1'000'000;
  return p;
}

}  // namespace

AutocollimatorDriver::AutocollimatorDriver(std::string name, std::size_t ring_capacity, AutocollimatorSettings settings)
    : LoopDriver(std::move(name), "autocollimator-serial", {{settings.x_channel, "rad"}, {settings.y_channel, "rad"}},
                 ring_capacity, policy_of(settings)),
      settings_(std::move(settings)) {}

AutocollimatorDriver::~AutocollimatorDriver() { stop(); }

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

void AutocollimatorDriver::open() {
  std::string error;
  line_ = serial::open_serial(settings_.serial, error);
  if (!line_) {
    link_failed(error);
    return;
  }
  link_up(line_->fd());
}

void AutocollimatorDriver::on_link_up(std::int64_t now_ns) {
  if (relinked()) after_gap_ = true;
  framer_.reset();
  out_.clear();
  link_closed_ = false;
  consecutive_timeouts_ = 0;
  awaiting_ = false;
  next_poll_ns_ = now_ns;
  if (settings_.stream) {
    std::string error;
    if (!send(format_request(Request::stream_start, static_cast<int>(settings_.stream_period_ms)), error)) {
      end_link("write: " + error);
      return;
    }
    deadline_ns_ = mono_now_ns() + settings_.reply_timeout_ms * 1'000'000;
  }
}

void AutocollimatorDriver::on_link_down() {
  if (settings_.stream) {  // best effort, never waiting: the instrument stops talking to nobody
    std::size_t written = 0;
    std::string ignored;
    (void)line_->write_some(format_request(Request::stream_stop), written, ignored);
  }
  line_.reset();
  out_.clear();
}

bool AutocollimatorDriver::flush_output(std::string& error) {
  while (!out_.empty()) {
    std::size_t written = 0;
    const serial::IoStatus st = line_->write_some(out_, written, error);
    if (st == serial::IoStatus::would_block) return true;
    if (st == serial::IoStatus::closed) {
      link_closed_ = true;
      error = "port closed";
      return false;
    }
    if (st == serial::IoStatus::error) return false;
    out_.erase(0, written);
  }
  return true;
}

bool AutocollimatorDriver::send(std::string_view data, std::string& error) {
  if (out_.empty()) write_deadline_ns_ = mono_now_ns() + settings_.reply_timeout_ms * 1'000'000;
  out_.append(data);
  return flush_output(error);
}

void AutocollimatorDriver::on_writable() {
  std::string error;
  if (!flush_output(error)) end_link(link_closed_ ? "port closed" : "write: " + error);
}

std::int64_t AutocollimatorDriver::service(std::int64_t now) {
  const std::int64_t timeout_ns = settings_.reply_timeout_ms * 1'000'000;
  const std::int64_t poll_ns = settings_.poll_period_ms * 1'000'000;
  const auto on_timeout = [&] {
    timeouts_.fetch_add(1, std::memory_order_relaxed);
    if (++consecutive_timeouts_ >= settings_.lost_after_timeouts) {
      set_state(drivers::DeviceState::lost, "no reply for " + std::to_string(consecutive_timeouts_) + " requests");
      after_gap_ = true;
    }
  };
  std::string error;
  if (!settings_.stream) {
    if (awaiting_ && now >= deadline_ns_) {
      awaiting_ = false;
      on_timeout();
    }
    if (!awaiting_ && now >= next_poll_ns_) {
      if (!send(format_request(settings_.relative ? Request::relative : Request::absolute), error)) {
        end_link(link_closed_ ? "port closed" : "write: " + error);
        return drivers::IoLoop::never;
      }
      awaiting_ = true;
      deadline_ns_ = now + timeout_ns;
      next_poll_ns_ = std::max(next_poll_ns_ + poll_ns, now);  // a late reply never causes a burst of requests
    }
  } else if (now >= deadline_ns_) {
    on_timeout();
    // Ask again: the instrument may have been reset.
    if (!send(format_request(Request::stream_start, static_cast<int>(settings_.stream_period_ms)), error)) {
      end_link("write: " + error);
      return drivers::IoLoop::never;
    }
    deadline_ns_ = mono_now_ns() + timeout_ns;
  }
  if (!out_.empty() && now >= write_deadline_ns_) {
    end_link("write: write timed out");
    return drivers::IoLoop::never;
  }
  want_write(!out_.empty());
  std::int64_t wake_at = deadline_ns_;
  if (!settings_.stream && !awaiting_) wake_at = next_poll_ns_;
  if (!out_.empty()) wake_at = std::min(wake_at, write_deadline_ns_);
  return wake_at;
}

drivers::ReadOutcome AutocollimatorDriver::read_some(bool) {
  drivers::ReadOutcome out;
  char buf[512];
  bool got_reading = false;
  std::string error;
  for (;;) {
    if (out.taken >= max_read_bytes) {  // a flooding line: the other devices first, then on
      out.more = true;
      break;
    }
    std::size_t got = 0;
    const auto st = line_->read_some(buf, sizeof buf, got, error);
    if (st == serial::IoStatus::closed) {
      out.ended = "port closed (device gone)";
      break;
    }
    if (st == serial::IoStatus::error) {
      out.ended = error;
      break;
    }
    if (got == 0) break;
    out.taken += got;
    line_end_ns_ = mono_now_ns();
    lines_.clear();
    const std::size_t overflows = framer_.feed(std::string_view(buf, got), lines_);
    bad_frames_.fetch_add(overflows, std::memory_order_relaxed);
    for (const auto& l : lines_) handle_line(l, got_reading);
    if (got < sizeof buf) break;  // the line is empty (or nearly: the next pass takes the rest)
  }
  if (got_reading) {
    if (consecutive_timeouts_ > 0) set_state(drivers::DeviceState::streaming);
    consecutive_timeouts_ = 0;
    awaiting_ = false;
    if (settings_.stream) deadline_ns_ = line_end_ns_ + settings_.reply_timeout_ms * 1'000'000;
  }
  return out;
}

void register_autocollimator_driver(drivers::DriverRegistry& registry) {
  registry.add("autocollimator-serial",
               "TA80-style two-axis autocollimator, ASCII over a serial line (libserialport; termios for ptys)",
               [](const drivers::DeviceConfig& c) {
                 AutocollimatorSettings s = parse_autocollimator_settings(c.table);
                 // One reading per request (poll) or per output period (stream).
                 const std::size_t ring = c.ring_for(1e3 / static_cast<double>(s.stream ? s.stream_period_ms
                                                                                           : s.poll_period_ms));
                 return std::make_unique<AutocollimatorDriver>(c.name, ring, std::move(s));
               });
}

}  // namespace guideway::drivers::autocollimator
