// The skeleton of every loop-driven driver (loop_driver.hpp): the timer and hooks, the link's states and back-off, the
// rest policy.
#include "drivers/loop_driver.hpp"

#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>

#include "core/mono_clock.hpp"
#include "drivers/tcp/tcp_client.hpp"

namespace guideway::drivers {

Reconnect read_reconnect(const TableReader& t, std::chrono::milliseconds default_min,
                         std::chrono::milliseconds default_max) {
  Reconnect r;
  // One key, under its name or its old one (never both); `used` gets the name the table gave.
  const auto read = [&](const std::string& key, const std::string& old, std::int64_t fallback, std::int64_t max,
                        std::string& used) {
    used = key;
    if (!t.has(old)) return t.get_int(key, fallback, 1, max);
    if (t.has(key)) t.fail(old, old + " is the old name of " + key + ": give " + key + " only");
    r.deprecated.push_back(t.path() + "." + old + " is deprecated: write " + key + " (the same meaning) in " +
                           t.file());
    used = old;
    return t.get_int(old, fallback, 1, max);
  };
  std::string min_key, max_key;
  const std::int64_t min_ms = read("reconnect_min_ms", "backoff_initial_ms", default_min.count(), 600000, min_key);
  const std::int64_t max_ms = read("reconnect_max_ms", "backoff_max_ms", default_max.count(), 3600000, max_key);
  if (max_ms < min_ms)
    t.fail(max_key, "must not be less than " + min_key + " (" + std::to_string(min_ms) + " ms): the waits double from " +
                        min_key + " up to it");
  r.backoff = Backoff::between(std::chrono::milliseconds(min_ms), std::chrono::milliseconds(max_ms));
  return r;
}

LoopDriver::LoopDriver(std::string name, std::string driver, std::vector<ChannelInfo> channels,
                       std::size_t ring_capacity, LoopPolicy policy)
    : Driver(std::move(name), std::move(driver), std::move(channels), ring_capacity),
      policy_(std::move(policy)),
      backoff_(policy_.reconnect.backoff) {
  set_sample_bound(std::chrono::nanoseconds(policy_.sample_bound_ns));
  for (const std::string& why : policy_.reconnect.deprecated) post_event({"deprecated_key", why, true});
  set_config_warnings(policy_.reconnect.deprecated);  // and in STATUS while it runs (the event is heard once)
}

void LoopDriver::on_silence(std::int64_t now_ns) {
  (void)now_ns;
  timeouts_.fetch_add(1, std::memory_order_relaxed);
  end_link("no data for " + std::to_string(policy_.silence_ns / 1'000'000) + " ms");
}

void LoopDriver::attach(IoLoop& loop) {
  io_ = &loop;
  backoff_ = policy_.reconnect.backoff;
  backoff_.reset();
  ever_up_ = false;
  timer_ = loop.add_timer([this] { on_timer(); });
  wake_hook_ = loop.add_wake_hook([this] { on_wake(); });
  settle_hook_ = loop.add_settle_hook([this] { on_settle(); });
  connect();
}

void LoopDriver::detach() {
  if (connector_attached_) connector_.detach();
  connector_attached_ = false;
  if (link_ == Link::up) on_stop();  // may end the link itself
  if (link_ == Link::up) close_link();
  link_ = Link::waiting;
  io_->remove_timer(timer_);
  io_->remove_hook(wake_hook_);
  io_->remove_hook(settle_hook_);
  io_ = nullptr;
}

void LoopDriver::connect() {
  link_ = Link::opening;
  open();
}

void LoopDriver::connect_tcp(const std::string& host, int port, std::string label, std::chrono::nanoseconds timeout) {
  if (!connector_attached_) {
    connector_.attach(
        *io_,
        [this](int fd) {
          tcp::set_stream_options(fd);
          up(fd, true);
        },
        [this](const std::string& error) { link_failed(error); });
    connector_attached_ = true;
  }
  // A state always says why: a status read while a new link opens after a loss would otherwise show a bare
  // `connecting` and hide the loss (the junk peer of driver_streaming_rule_test, caught in that instant).
  std::string doing = "connecting to " + label;
  if (!last_end_.empty()) doing += " (the last link: " + last_end_ + ")";
  set_state(DeviceState::connecting, std::move(doing));
  link_ = Link::opening;
  connector_.start(host, port, std::move(label), timeout);
}

void LoopDriver::link_up(int fd) { up(fd, false); }

void LoopDriver::link_failed(const std::string& why) {
  link_ = Link::waiting;
  last_end_ = why;
  set_state(ever_up_ || !policy_.unreached_is_error ? DeviceState::lost : DeviceState::error, why);
  wait_backoff();
}

void LoopDriver::wait_backoff() {
  reconnect_at_ns_ = mono_now_ns() + backoff_.take_ns();
  io_->arm(timer_, reconnect_at_ns_);
}

void LoopDriver::up(int fd, bool owned) {
  fd_ = fd;
  owns_fd_ = owned;
  link_ = Link::up;
  relinked_ = ever_up_;
  if (relinked_) reconnects_.fetch_add(1, std::memory_order_relaxed);
  ever_up_ = true;
  published_at_up_ = published_samples();
  mark_link_up();
  set_state(DeviceState::streaming);
  const std::int64_t now = mono_now_ns();
  schedule_ = policy_.schedule;
  last_data_ns_ = now;
  read_at_ns_ = now;  // wait for the first arrival
  deadline_ns_ = IoLoop::never;
  service_slack_ns_ = 0;
  resting_ = idle_check_ = lonely_ = others_pass_ = write_wanted_ = false;
  io_->watch(fd_, 0, [this](std::uint32_t events) { on_ready(events); });
  on_link_up(now);
  if (link_ == Link::up) tick(mono_now_ns());
}

void LoopDriver::close_link() {
  io_->unwatch(fd_);
  on_link_down();
  if (owns_fd_) ::close(fd_);
  fd_ = -1;
  link_ = Link::waiting;
}

void LoopDriver::end_link(const std::string& why) {
  if (link_ != Link::up) return;
  close_link();
  // After a link that gave samples the next attempt comes soon; a peer that takes the connection and
  // gives nothing (junk, silence, a close) is tried less and less often.
  if (published_samples() > published_at_up_) backoff_.reset();
  last_end_ = why;
  set_state(DeviceState::lost, why);
  wait_backoff();
}

void LoopDriver::on_ready(std::uint32_t events) {
  if (link_ != Link::up) return;
  served_pass_ = io_->passes();
  if ((events & EPOLLOUT) != 0) {
    on_writable();
    if (link_ != Link::up) return;
  }
  if ((events & (EPOLLHUP | EPOLLERR)) != 0) {
    hang_up();
    return;
  }
  if ((events & EPOLLIN) != 0) {
    if (schedule_ == ReadSchedule::rest) read_at_ns_ = mono_now_ns();  // an arrival after an empty read: read now
    if (read(false)) tick(mono_now_ns());
    return;
  }
  tick(mono_now_ns());
}

void LoopDriver::hang_up() {
  // The connection ends: everything still queued first (the end comes after it).
  std::string ended;
  bool more = true;
  while (more && ended.empty()) {
    ReadOutcome r = read_some(false);
    if (link_ != Link::up) return;
    more = r.more;
    ended = std::move(r.ended);
  }
  if (ended.empty()) {
    int err = 0;
    socklen_t len = sizeof err;
    if (::getsockopt(fd_, SOL_SOCKET, SO_ERROR, &err, &len) != 0) err = 0;
    ended = err != 0 ? std::string("socket error: ") + std::strerror(err) : "connection hung up";
  }
  end_link(ended);
}

bool LoopDriver::read(bool at_others_pass) {
  served_pass_ = io_->passes();
  bool more = false;
  return read_once(at_others_pass, more);
}

bool LoopDriver::read_queued(bool& more) { return read_once(false, more); }

bool LoopDriver::read_once(bool at_others_pass, bool& more) {
  const std::uint64_t before = published_samples();
  const ReadOutcome r = read_some(at_others_pass);
  more = r.more;
  if (link_ != Link::up) return false;
  if (!r.ended.empty()) {
    end_link(r.ended);
    return false;
  }
  after_read(r, published_samples() > before, at_others_pass, mono_now_ns());
  return true;
}

void LoopDriver::after_read(const ReadOutcome& r, bool samples, bool at_others_pass, std::int64_t now) {
  const std::int64_t period_ns = policy_.read_period_ns;
  if (r.taken > 0) {
    io_->data_found();
    last_data_ns_ = now;
    if (schedule_ != ReadSchedule::rest) {
      if (r.more) io_->again();
      return;
    }
    if (others_pass_) lonely_ = false;
    others_pass_ = false;
    // A flood of data is read on at the next pass, after the other devices; a read that gave no sample
    // (junk, a flood of it included) rests like any other, so garbage never costs more reads than data.
    const bool flood = r.more && samples;
    const bool rests = period_ns > 0 && (!samples || (!flood && !lonely_ && rest_after(r)));
    read_at_ns_ = rests ? now + period_ns : now;
    if (flood) io_->again();
    return;
  }
  if (schedule_ != ReadSchedule::rest) return;
  // Nothing came. Read at another device's pass, or at the end of a rest: rest on (the end of a rest is
  // settled once the pass has read every device: on_settle). After readiness: the next arrival wakes us.
  if (at_others_pass || resting_) read_at_ns_ = now + period_ns;
  idle_check_ = !at_others_pass && resting_;
}

void LoopDriver::on_timer() {
  const std::int64_t now = mono_now_ns();
  switch (link_) {
    case Link::opening:
      return;  // the connector's own timer
    case Link::waiting:
      if (now < reconnect_at_ns_) {
        io_->arm(timer_, reconnect_at_ns_);
        return;
      }
      connect();
      return;
    case Link::up:
      break;
  }
  const bool rest_over = schedule_ == ReadSchedule::rest && resting_ && now >= read_at_ns_;
  if (rest_over && served_pass_ != io_->passes()) {
    if (read(false)) tick(mono_now_ns());
    return;
  }
  served_pass_ = io_->passes();
  tick(now);
}

void LoopDriver::on_wake() {
  if (link_ != Link::up || served_pass_ == io_->passes()) return;
  others_pass_ = true;  // a pass this driver did not cause: another device keeps the loop busy
  foreign_pass_ = io_->passes();
  const std::int64_t now = io_->now();
  if (schedule_ == ReadSchedule::rest && now < read_at_ns_) {
    if (read(true)) tick(mono_now_ns());
    return;
  }
  if (service_slack_ns_ > 0 && deadline_ns_ != IoLoop::never && now >= deadline_ns_ - service_slack_ns_) tick(now);
}

void LoopDriver::on_settle() {
  if (!idle_check_ || link_ != Link::up) return;
  idle_check_ = false;
  if (io_->data_found_this_pass()) return;  // others stream: read again at their next pass
  const std::int64_t now = mono_now_ns();
  read_at_ns_ = now;  // nothing anywhere: the next arrival wakes us
  if (policy_.alone_reads_per_arrival) {
    lonely_ = true;
    others_pass_ = false;
  }
  arm(now);
}

void LoopDriver::tick(std::int64_t now) {
  if (policy_.silence_ns > 0 && now - last_data_ns_ >= policy_.silence_ns) {
    last_data_ns_ = now;  // one per silent period
    on_silence(now);
    if (link_ != Link::up) return;
  }
  deadline_ns_ = service(now);
  if (link_ != Link::up) return;
  arm(mono_now_ns());
}

void LoopDriver::arm(std::int64_t now) {
  const bool resting = schedule_ == ReadSchedule::rest && now < read_at_ns_;
  resting_ = resting;
  const bool reads = schedule_ != ReadSchedule::paced && !resting;
  io_->modify(fd_, (reads ? std::uint32_t{EPOLLIN} : 0u) | (write_wanted_ ? std::uint32_t{EPOLLOUT} : 0u));
  std::int64_t deadline = deadline_ns_;
  if (policy_.silence_ns > 0) deadline = std::min(deadline, last_data_ns_ + policy_.silence_ns);
  if (resting) deadline = std::min(deadline, read_at_ns_);
  io_->arm(timer_, deadline);
}

}  // namespace guideway::drivers
