// "micrometer-modbus" (micrometer_driver.hpp): a gauge amplifier over Modbus TCP or RTU, polled or read from its sample
// buffer.
#include "drivers/micrometer/micrometer_driver.hpp"

#include <poll.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <coroutine>
#include <cstring>
#include <exception>
#include <optional>
#include <utility>
#include <vector>

#include "drivers/modbus/modbus_tcp.hpp"

#include "core/mono_clock.hpp"
#include "core/number_format.hpp"

namespace guideway::drivers::micrometer {

MicrometerConfig parse_micrometer_config(const TableReader& t) {
  MicrometerConfig c;
  c.endpoint = modbus::parse_endpoint(t);
  if (auto buffer = t.table("buffer")) {
    if (t.has("registers")) {
      t.fail("buffer", "[device.buffer] (buffered mode) and [device.registers] (polled mode) exclude each other");
    }
    if (t.has("poll_hz")) t.fail("poll_hz", "buffered mode ([device.buffer]) polls every poll_period_ms, not poll_hz");
    c.buffer = modbus::parse_sample_ring(*buffer);
    buffer->reject_unknown_keys();
    c.poll_period_ms = t.get_double("poll_period_ms", default_buffer_poll_period_ms, 0.1, 60000.0);
    // Half the ring is left for a late poll (a retried request, a busy machine) before samples are lost.
    const double per_poll = c.poll_period_ms * 1e-3 * c.buffer->sample_rate_hz;
    if (per_poll > c.buffer->ring_samples / 2.0) {
      std::string why = "the amplifier takes ";
      append_shortest(why, per_poll);
      t.fail("poll_period_ms", why + " samples per poll, more than half its ring (" +
                                   std::to_string(c.buffer->ring_samples) + " samples): poll faster");
    }
  } else {
    if (auto regs = t.table("registers")) {
      c.map = modbus::parse_register_map(*regs);
      regs->reject_unknown_keys();
    }
    if (t.has("poll_period_ms"))
      t.fail("poll_period_ms", "only in buffered mode ([device.buffer]); polled mode uses poll_hz");
    c.poll_hz = t.get_double("poll_hz", 50.0, 0.01, 10000.0);
  }
  c.lost_after_failures = static_cast<int>(t.get_int("lost_after_failures", 3, 1, 1000));
  c.reconnect = drivers::read_reconnect(t, std::chrono::milliseconds(100), std::chrono::milliseconds(5000));
  return c;
}

// Where buffered mode stands; kept across reconnects, so samples taken during a short outage are
// fetched from the amplifier's ring afterwards.
struct MicrometerDriver::RingCursor {
  // A 0.2 s anchor window: a device slow by up to the rate tolerance makes stamps early by at most
  // 0.2 s x 0.5 % = 1 ms; beyond it the state says so.
  explicit RingCursor(double rate_hz) : anchor(rate_hz, 200'000'000), stamps(rate_hz) {}
  modbus::CounterTracker counter;
  modbus::TimeAnchor anchor;       // sample number -> CLOCK_MONOTONIC, from the last 0.2 s of counter reads
  std::uint64_t next = 0;          // the next sample number to publish
  std::int64_t last_query_ns = 0;  // when the last good counter read was sent
  modbus::StampSequencer stamps;   // published timestamps only increase, by >= half a period a sample
  bool gap = false;                // the next published sample follows lost ones
  int resets_in_row = 0;           // counter reads in a row that looked like an amplifier restart
  // After three of them, when the counter's steps first looked plausible again: one such step proves
  // nothing on a loaded machine (a late answer to the poll before stretches the time a step may span).
  std::optional<std::int64_t> plausible_since_ns;
  bool rate_flagged = false;       // the measured rate is off sample_rate_hz by more than the tolerance
  bool overrun_counted = false;    // this poll already counted its ring overrun
};

namespace {
// How long a counter flagged as too fast must step plausibly before the error clears. A run of steps
// that only looked plausible because answers came late cannot last this long: the polls' round trips
// follow one another, so their latencies cannot add up to several times the run (a counter 2.1x fast
// or more would need that).
constexpr std::int64_t counter_plausible_again_ns = 500'000'000;
// How far the amplifier's measured rate may be off sample_rate_hz before the state says so.
constexpr double rate_tolerance = 0.005;
}  // namespace

// A poll as a coroutine that never does I/O itself: at every register read it suspends (ask()), and
// the transport resumes it with the answer in xs_. Created suspended; run and destroyed by its owner.
class MicrometerDriver::PollTask {
 public:
  struct promise_type {
    PollTask get_return_object() noexcept { return PollTask(std::coroutine_handle<promise_type>::from_promise(*this)); }
    std::suspend_always initial_suspend() noexcept { return {}; }
    std::suspend_always final_suspend() noexcept { return {}; }
    void return_void() noexcept {}
    void unhandled_exception() noexcept { std::terminate(); }  // a poll throws nothing: a bug
  };
  explicit PollTask(std::coroutine_handle<promise_type> h) noexcept : h_(h) {}
  PollTask(PollTask&& o) noexcept : h_(std::exchange(o.h_, {})) {}
  PollTask& operator=(PollTask&&) = delete;
  ~PollTask() {
    if (h_) h_.destroy();
  }
  [[nodiscard]] bool done() const noexcept { return !h_ || h_.done(); }
  void resume() { h_.resume(); }

 private:
  std::coroutine_handle<promise_type> h_;
};

struct MicrometerDriver::ReadAwaiter {
  const Exchange& x;
  [[nodiscard]] bool await_ready() const noexcept { return false; }
  void await_suspend(std::coroutine_handle<>) const noexcept {}
  [[nodiscard]] const modbus::ReadResult& await_resume() const noexcept { return x.result; }
};

namespace {

std::chrono::nanoseconds poll_period_of(const MicrometerConfig& c) {
  return std::chrono::nanoseconds(c.buffer ? static_cast<std::int64_t>(c.poll_period_ms * 1e6)
                                           : static_cast<std::int64_t>(1e9 / c.poll_hz));
}

drivers::LoopPolicy policy_of(const MicrometerConfig& c) {
  drivers::LoopPolicy p;
  p.reconnect = c.reconnect;
  p.schedule = drivers::ReadSchedule::per_arrival;  // a poll that may share the others' passes rests (send_request)
  // Lost after lost_after_failures polls without an answer.
  p.sample_bound_ns =
      c.lost_after_failures * (poll_period_of(c) + std::chrono::nanoseconds(c.endpoint.response_timeout)).count();
  return p;
}

}  // namespace

MicrometerDriver::MicrometerDriver(std::string name, MicrometerConfig config, std::size_t ring_capacity)
    : LoopDriver(std::move(name), "micrometer-modbus", {{"displacement", "m"}}, ring_capacity, policy_of(config)),
      config_(std::move(config)) {
  rx_.reserve(2 * modbus::max_tcp_answer_bytes);
}

MicrometerDriver::~MicrometerDriver() { stop(); }

MicrometerDriver::ReadAwaiter MicrometerDriver::ask(modbus::RegisterFunction function, std::uint16_t address,
                                                    std::uint16_t count) noexcept {
  Exchange& x = xs_[0];
  x.function = function;
  x.address = address;
  x.count = count;
  asked_ = 1;
  return {x};
}

MicrometerDriver::ReadAwaiter MicrometerDriver::ask_all(std::size_t n) noexcept {
  asked_ = std::clamp<std::size_t>(n, 1, xs_.size());
  return {xs_[0]};
}

std::chrono::nanoseconds MicrometerDriver::poll_period() const noexcept { return poll_period_of(config_); }

void MicrometerDriver::new_link(bool relinked) {
  if (relinked) gap_ = true;
  failures_ = 0;
  link_gone_ = false;
  end_link_ = false;
  last_failure_.clear();
}

MicrometerDriver::PollTask MicrometerDriver::make_poll() { return config_.buffer ? buffered_poll() : polled_poll(); }

MicrometerDriver::PollTask MicrometerDriver::polled_poll() {
  const std::uint16_t start = config_.map.block_start();
  const std::uint16_t count = config_.map.block_count();
  const modbus::ReadResult& r = co_await ask(config_.map.function, start, count);
  if (r.status == modbus::ReadStatus::ok) {
    frames_.fetch_add(1, std::memory_order_relaxed);
    const modbus::Reading reading = modbus::decode_registers(config_.map, xs_[0].block);
    Sample s;
    s.t_mono_ns = xs_[0].t_answer_ns;
    s.value_count = 1;
    s.value[0] = reading.value_m;
    s.flags = reading.flags | (gap_ ? sample_after_gap : 0u);
    publish(s);
    gap_ = false;
    failures_ = 0;
  } else if (r.status == modbus::ReadStatus::disconnected) {
    last_failure_ = count_failure(r);
    failures_ = config_.lost_after_failures;
  } else {
    last_failure_ = count_failure(r);
    ++failures_;
    gap_ = true;
  }
  end_link_ = failures_ >= config_.lost_after_failures;
}

std::string MicrometerDriver::count_failure(const modbus::ReadResult& r) {
  if (r.status == modbus::ReadStatus::disconnected) return "disconnected: " + r.message;
  if (r.status == modbus::ReadStatus::timeout) {
    timeouts_.fetch_add(1, std::memory_order_relaxed);
  } else {
    bad_frames_.fetch_add(1, std::memory_order_relaxed);
    if (r.status == modbus::ReadStatus::exception) exceptions_.fetch_add(1, std::memory_order_relaxed);
  }
  return std::string(modbus::to_string(r.status)) + ": " + r.message;
}

void MicrometerDriver::failed(const modbus::ReadResult& r) {
  last_failure_ = count_failure(r);
  if (r.status == modbus::ReadStatus::disconnected) {
    link_gone_ = true;
  } else {
    ++failures_;
  }
}

void MicrometerDriver::count_stale(std::uint64_t total) noexcept {
  if (total == stale_seen_) return;
  count_stale_frames(total - stale_seen_);
  stale_seen_ = total;
}

void MicrometerDriver::count_stale_frames(std::uint64_t n) noexcept {
  bad_frames_.fetch_add(n, std::memory_order_relaxed);
  stale_answers_.fetch_add(n, std::memory_order_relaxed);
}

void MicrometerDriver::lose(std::uint64_t n) noexcept {
  if (n == 0) return;
  RingCursor& cursor = *cursor_;
  // One overrun per poll that found samples overwritten, however many of its reads saw it; counted
  // before the samples (release), so that a reader of lost_samples (acquire) then ring_overruns never
  // sees samples lost without an overrun.
  if (!cursor.overrun_counted) {
    ring_overruns_.fetch_add(1, std::memory_order_relaxed);
    cursor.overrun_counted = true;
  }
  lost_samples_.fetch_add(n, std::memory_order_release);
  skip_samples(n);
  cursor.gap = true;
}

bool MicrometerDriver::take_counter(const Exchange& x, std::int64_t t_query) {
  const modbus::SampleRingMap& ring = *config_.buffer;
  const double rate = ring.sample_rate_hz;
  RingCursor& cursor = *cursor_;
  const modbus::ReadResult& r = x.result;
  const std::int64_t t_answer = x.t_answer_ns;
  if (r.status != modbus::ReadStatus::ok) {
    failed(r);
    return false;
  }
  frames_.fetch_add(1, std::memory_order_relaxed);
  const double elapsed_s = static_cast<double>(t_answer - cursor.last_query_ns) * 1e-9;
  const std::uint32_t counter = modbus::decode_counter(ring, x.block[0], x.block[1]);
  const bool backwards =
      cursor.counter.started() && counter - static_cast<std::uint32_t>(cursor.counter.count()) >= 0x80000000u;
  const auto step = cursor.counter.update(counter, elapsed_s, rate);
  cursor.last_query_ns = t_query;
  const std::uint64_t count = cursor.counter.count();
  const auto say_counter_too_fast = [&] {
    std::string why = "the sample counter runs faster than sample_rate_hz = ";
    append_shortest(why, rate);
    set_state(drivers::DeviceState::error, why + " (or the amplifier keeps restarting): check [device.buffer]");
  };
  if (step == modbus::CounterTracker::Step::advanced && cursor.resets_in_row > 0) {
    if (cursor.resets_in_row < 3) {
      cursor.resets_in_row = 0;
    } else {
      if (!cursor.plausible_since_ns) cursor.plausible_since_ns = t_answer;
      if (t_answer - *cursor.plausible_since_ns >= counter_plausible_again_ns) {
        set_state(drivers::DeviceState::streaming);
        cursor.resets_in_row = 0;
        cursor.plausible_since_ns.reset();
      } else {
        say_counter_too_fast();  // again: a reconnect sets the state to streaming
      }
    }
  }
  if (step != modbus::CounterTracker::Step::advanced) {
    // Start at the newest sample (first read), or after a restart of the amplifier: what it took
    // before the restart is not in this count, so it cannot be fetched or numbered; the next sample says so.
    if (step == modbus::CounterTracker::Step::reset) {
      counter_resets_.fetch_add(1, std::memory_order_relaxed);
      cursor.gap = true;
      cursor.plausible_since_ns.reset();
      // A restart now and then is an amplifier; one at every poll is a counter running faster
      // than the configured rate, and nothing would ever be published: say so, again after every
      // further one (a reconnect sets the state to streaming; the count survives it).
      if (++cursor.resets_in_row >= 3) say_counter_too_fast();
    }
    cursor.next = count;
    // A counter that went backwards is an amplifier that restarted (from 0): what its ring took
    // since then is in this epoch, [epoch start, count): resume at its oldest intact sample.
    if (backwards) cursor.next = std::max(count & ~((std::uint64_t{1} << 32) - 1), modbus::oldest_intact(ring, count));
    cursor.anchor.reset(count > 0 ? count - 1 : 0);
    cursor.stamps.restart();
  }
  cursor.anchor.observe(t_answer, count);
  if (const auto e = cursor.anchor.rate_error()) {
    if (std::abs(*e) > rate_tolerance) {  // asserted at every poll: a reconnect sets streaming
      std::string why = "the sample counter runs ";
      append_shortest(why, std::round(std::abs(*e) * 1e4) / 100.0);
      why += *e < 0 ? " % slower" : " % faster";
      why += " than sample_rate_hz = ";
      append_shortest(why, rate);
      why += " (measured ";
      append_shortest(why, std::round(rate * (1.0 + *e)));
      set_state(drivers::DeviceState::error, why + " Hz): timestamps are off; check [device.buffer]");
      cursor.rate_flagged = true;
    } else if (cursor.rate_flagged) {
      cursor.rate_flagged = false;
      set_state(drivers::DeviceState::streaming);
    }
  }
  return true;
}

MicrometerDriver::PollTask MicrometerDriver::buffered_poll() {
  const modbus::SampleRingMap& ring = *config_.buffer;
  const double rate = ring.sample_rate_hz;
  RingCursor& cursor = *cursor_;
  readings_.resize(ring.samples_per_request());
  cursor.overrun_counted = false;
  std::int64_t t_query = mono_now_ns();
  // Over TCP the ring's new part goes out with the counter read, as far as the amplifier will have
  // got by now (its rate, 2 % and 2 samples more; what it has not written yet is dropped once the
  // counter says so): a poll is one round trip, not one per read, and its samples wait in the socket
  // for one pass of the loop, not three.
  std::vector<modbus::RingRead> ahead;
  if (!rtu() && !one_at_a_time_ && cursor.counter.started()) {
    const double since_s = static_cast<double>(t_query - cursor.last_query_ns) * 1e-9;
    const auto taken = static_cast<std::uint64_t>(std::max(0.0, rate * since_s * 1.02) + 2.0);
    ahead = modbus::plan_ring_reads(ring, cursor.next, cursor.counter.count() + taken);
    if (ahead.size() > max_reads_ahead) ahead.resize(max_reads_ahead);
  }
  const std::uint64_t next_asked = cursor.next;
  (void)ask(ring.function, ring.counter_address, 2);
  for (std::size_t i = 0; i < ahead.size(); ++i) {
    xs_[1 + i].function = ring.function;
    xs_[1 + i].address = ahead[i].address;
    xs_[1 + i].count = ahead[i].count;
  }
  (void)co_await ask_all(1 + ahead.size());
  bool ok = take_counter(xs_[0], t_query);
  if (ok) {
    const std::uint64_t count = cursor.counter.count();
    if (const std::uint64_t oldest = modbus::oldest_intact(ring, count); cursor.next < oldest) {
      lose(oldest - cursor.next);  // the ring lapped since the last poll
      cursor.next = oldest;
    }
    const std::int64_t t_counter = cursor.last_query_ns;
    // The reads of [cursor.next, count): those answered with the counter (answer: their exchange),
    // while the numbering held (no lap, no restart), then the rest, asked one by one (answer 0).
    struct Planned {
      modbus::RingRead read;
      std::uint64_t end = 0;
      std::size_t answer = 0;
    };
    std::vector<Planned> plan;
    std::uint64_t planned_to = cursor.next;
    for (std::size_t i = 0; cursor.next == next_asked && i < ahead.size() && ahead[i].first < count; ++i) {
      planned_to = std::min<std::uint64_t>(ahead[i].first + ahead[i].samples, count);
      plan.push_back({ahead[i], planned_to, 1 + i});
    }
    for (const modbus::RingRead& rr : modbus::plan_ring_reads(ring, planned_to, count)) {
      plan.push_back({rr, rr.first + rr.samples, 0});
    }
    for (const Planned& p : plan) {
      const modbus::RingRead& rr = p.read;
      if (p.answer == 0) (void)co_await ask(ring.function, rr.address, rr.count);
      const Exchange& x = xs_[p.answer];
      if (x.result.status != modbus::ReadStatus::ok) {
        failed(x.result);
        ok = false;
        break;
      }
      frames_.fetch_add(1, std::memory_order_relaxed);
      modbus::decode_ring_block(ring, rr, x.block, readings_);
      // Samples near the ring's tail may have been overwritten while the requests were under way:
      // bound how far the amplifier can have got, and when that reaches them, ask it.
      std::uint64_t first = rr.first;
      const double since_s = static_cast<double>(mono_now_ns() - t_counter) * 1e-9;
      const auto could = count + static_cast<std::uint64_t>(rate * since_s * 1.05 + 2.0);
      if (modbus::oldest_intact(ring, could) > first) {
        t_query = mono_now_ns();
        (void)co_await ask(ring.function, ring.counter_address, 2);
        if (!take_counter(xs_[0], t_query)) {
          ok = false;
          break;
        }
        const std::uint64_t intact = modbus::oldest_intact(ring, cursor.counter.count());
        if (cursor.next != rr.first) break;  // the amplifier restarted: start again at the next poll
        if (intact > first) {
          lose(std::min<std::uint64_t>(intact, p.end) - first);
          first = std::min<std::uint64_t>(intact, p.end);
        }
      }
      for (std::uint64_t k = first; k < p.end; ++k) {
        const modbus::Reading& reading = readings_[k - rr.first];
        Sample s;
        s.t_mono_ns = cursor.stamps.stamp(k, cursor.anchor.time_ns(k));
        s.value_count = 1;
        s.value[0] = reading.value_m;
        s.flags = reading.flags | (cursor.gap ? sample_after_gap : 0u);
        cursor.gap = false;
        publish(s);
      }
      cursor.next = p.end;
    }
  }
  end_link_ = link_gone_ || failures_ >= config_.lost_after_failures;
  if (!end_link_ && ok) failures_ = 0;
}

// ---- The I/O loop: Modbus TCP on the socket, RTU through the line's thread.

void MicrometerDriver::open() {
  if (rtu()) {
    if (!rtu_) rtu_ = std::make_unique<modbus::RtuLine>(config_.endpoint);
    std::string error;
    if (rtu_->open(error)) {
      link_up(rtu_->fd());
    } else {
      link_failed(error);
    }
    return;
  }
  // libmodbus waits a response timeout for the connection too.
  connect_tcp(config_.endpoint.host, config_.endpoint.port, config_.endpoint.describe(),
              config_.endpoint.response_timeout);
}

void MicrometerDriver::on_link_up(std::int64_t now_ns) {
  if (!relinked()) {  // a start: no ring cursor from an earlier start
    gap_ = false;
    cursor_ = std::make_unique<RingCursor>(config_.buffer ? config_.buffer->sample_rate_hz : 1.0);
  }
  new_link(relinked());
  ask_ = Ask::idle;
  next_poll_ns_ = now_ns;  // service() starts the first poll
  early_ns_ = 0;
}

void MicrometerDriver::on_stop() {
  // The one wait on the loop's thread: when a device stops, for its answers, each within
  // response_timeout_ms (over RTU, as long as the line takes to answer the reads under way).
  if (rtu()) {
    while (poll_ && link_is_up() && ask_ == Ask::awaiting) {
      rtu_->wait();
      (void)read_some(false);
    }
    return;
  }
  while (poll_ && link_is_up() && ask_ == Ask::awaiting) {
    const std::int64_t left = deadline_ns_ - mono_now_ns();
    if (left <= 0) break;
    pollfd p{link_fd(), POLLIN, 0};
    const timespec ts{static_cast<time_t>(left / 1'000'000'000), static_cast<long>(left % 1'000'000'000)};
    if (::ppoll(&p, 1, &ts, nullptr) < 0 && errno != EINTR) break;
    const drivers::ReadOutcome r = read_some(false);
    if (!r.ended.empty()) break;
  }
}

void MicrometerDriver::on_link_down() {
  if (rtu_) rtu_->close();  // after the reads under way: they write into xs_
  poll_.reset();
  rx_.clear();
  ask_ = Ask::idle;
}

std::size_t MicrometerDriver::read_socket(std::string& ended) {
  std::uint8_t buf[1024];
  std::size_t taken = 0;
  for (;;) {
    const tcp::ReadResult r = tcp::read_some(link_fd(), reinterpret_cast<char*>(buf), sizeof buf);
    if (r.status == tcp::ReadStatus::would_block) return taken;
    if (r.status != tcp::ReadStatus::data) {
      ended = r.message;
      return taken;
    }
    taken += r.bytes;
    if (ask_ == Ask::awaiting) {
      rx_.insert(rx_.end(), buf, buf + r.bytes);
      // The answer's time: when the kernel received it (the anchor of buffered mode's stamps).
      std::int64_t t = mono_now_ns();
      if (r.rx_realtime_ns != tcp::no_rx_timestamp) {
        const std::int64_t k = r.rx_realtime_ns - realtime_minus_mono_ns();
        if (k >= sent_ns_ - 1'000'000 && k <= t + 1'000'000) t = std::clamp(k, sent_ns_, t);
      }
      rx_ns_ = t;
      if (rx_.size() > 4 * modbus::max_tcp_answer_bytes) return taken;  // a flood: parse what is there first
    }
    // Idle: late or repeated answers to an earlier poll's requests, dropped as libmodbus's flush drops them.
  }
}

drivers::ReadOutcome MicrometerDriver::read_some(bool) {
  drivers::ReadOutcome out;
  if (rtu()) {
    if (!rtu_->answered()) return out;
    out.taken = asked_;
    count_stale(rtu_->stale_answers());
    if (ask_ == Ask::awaiting) {
      answered_ = asked_;
      all_answered();  // may end the link (a poll that gives it up)
    }
    return out;
  }
  std::string ended;
  out.taken = read_socket(ended);
  if (!ended.empty()) {
    if (ask_ == Ask::awaiting) {
      answer({modbus::ReadStatus::disconnected, 0, ended}, mono_now_ns());  // the poll ends the link
    } else {
      out.ended = "disconnected: " + ended;
    }
    return out;
  }
  if (ask_ == Ask::awaiting) take_answers();
  return out;
}

void MicrometerDriver::take_answers() {
  for (;;) {
    // The answers come in the order asked (a Modbus TCP server answers a connection's requests in turn).
    Exchange& x = xs_[answered_];
    const auto transaction = static_cast<std::uint16_t>(transaction_ - (asked_ - 1 - answered_));
    const modbus::TcpAnswer a = modbus::parse_tcp_answer(
        rx_, transaction, static_cast<std::uint8_t>(config_.endpoint.unit_id), x.function, x.count, x.block);
    switch (a.kind) {
      case modbus::TcpAnswer::Kind::incomplete:
        return;  // the rest comes, or the response timeout
      case modbus::TcpAnswer::Kind::other_transaction: {
        // A late answer to a request that timed out (or a repeated one): never taken for this one.
        // An answer to a later request of this ask means the server passed over this one: the ask
        // fails at its timeout as a whole, and that answer is no stale one.
        const auto after = static_cast<std::uint16_t>(((rx_[0] << 8) | rx_[1]) - transaction);
        rx_.erase(rx_.begin(), rx_.begin() + static_cast<std::ptrdiff_t>(a.length));
        if (after == 0 || after >= asked_ - answered_) count_stale_frames(1);
        continue;
      }
      case modbus::TcpAnswer::Kind::registers:
        rx_.erase(rx_.begin(), rx_.begin() + static_cast<std::ptrdiff_t>(a.length));
        x.result = {};
        break;
      case modbus::TcpAnswer::Kind::exception:
        rx_.erase(rx_.begin(), rx_.begin() + static_cast<std::ptrdiff_t>(a.length));
        x.result = {modbus::ReadStatus::exception, a.exception_code, modbus::exception_text(a.exception_code)};
        break;
      case modbus::TcpAnswer::Kind::bad:
        rx_.clear();  // nothing after it can be trusted
        answer({modbus::ReadStatus::bad_frame, 0, a.why}, rx_ns_);
        return;
    }
    x.t_answer_ns = rx_ns_;
    if (++answered_ == asked_) {
      if (asked_ > 1) partly_answered_ = 0;
      all_answered();
      return;
    }
  }
}

std::int64_t MicrometerDriver::service(std::int64_t now) {
  if (ask_ == Ask::awaiting && now >= deadline_ns_) {
    rx_.clear();  // a part of an answer that stopped half way is dropped with it
    // Some of a pipelined ask answered, the rest never, twice in a row (once is a lost answer): an
    // amplifier that takes one request at a time and drops the others; from now on it is asked so.
    if (asked_ > 1 && answered_ > 0 && ++partly_answered_ >= 2) one_at_a_time_ = true;
    answer({modbus::ReadStatus::timeout, 0, std::strerror(ETIMEDOUT)}, now);
  } else if (ask_ == Ask::idle && now >= next_poll_ns_ - early_ns_) {
    start_poll();
  }
  if (!link_is_up()) return drivers::IoLoop::never;
  return ask_ == Ask::awaiting ? deadline_ns_ : next_poll_ns_;
}

void MicrometerDriver::start_poll() {
  // While other devices keep the loop passing by (at least every read period), a buffered poll starts
  // at one of their passes (up to a fifth of a period early: finish_poll) and its socket keeps no
  // readiness interest between polls; its answers are read as they come (send_request).
  busy_ = config_.buffer.has_value() && others_passed_since(poll_pass_);
  poll_pass_ = loop().passes();
  early_ns_ = 0;
  set_service_slack(0);
  // Stray or late answers must not be taken for this poll's.
  if (rtu()) {
    flush_next_ = true;  // by the line, before its first read
  } else {
    rx_.clear();
    std::string ended;
    (void)read_socket(ended);
    if (!ended.empty()) {
      end_link("disconnected: " + ended);
      return;
    }
  }
  poll_ = std::make_unique<PollTask>(make_poll());
  continue_poll();
}

void MicrometerDriver::continue_poll() {
  poll_->resume();
  if (poll_->done()) {
    finish_poll();
    return;
  }
  send_request();
}

void MicrometerDriver::send_request() {
  if (rtu()) {
    answered_ = 0;
    sent_ns_ = mono_now_ns();
    ask_ = Ask::awaiting;
    deadline_ns_ = drivers::IoLoop::never;  // the line times out each read itself
    rtu_->ask(std::span<Exchange>(xs_.data(), asked_), std::exchange(flush_next_, false));
    set_schedule(drivers::ReadSchedule::per_arrival);  // the answers are taken as they come
    return;
  }
  // Every request of the ask in one write.
  std::array<std::uint8_t, (1 + max_reads_ahead) * modbus::tcp_request_bytes> requests{};
  for (std::size_t i = 0; i < asked_; ++i) {
    const Exchange& x = xs_[i];
    const auto one = modbus::tcp_read_request(++transaction_, static_cast<std::uint8_t>(config_.endpoint.unit_id),
                                              x.function, x.address, x.count);
    std::copy(one.begin(), one.end(), requests.begin() + static_cast<std::ptrdiff_t>(i * one.size()));
  }
  const std::size_t size = asked_ * modbus::tcp_request_bytes;
  answered_ = 0;
  rx_.clear();
  sent_ns_ = mono_now_ns();
  const ssize_t put = ::send(link_fd(), requests.data(), size, MSG_NOSIGNAL | MSG_DONTWAIT);
  ask_ = Ask::awaiting;
  if (put != static_cast<ssize_t>(size)) {
    // At most 48 bytes on an idle connection: refused only when the connection is gone (or never drains).
    const std::string why = put < 0 ? std::strerror(errno) : "short write of a request";
    answer({put < 0 && (errno == EAGAIN || errno == EWOULDBLOCK) ? modbus::ReadStatus::timeout
                                                                 : modbus::ReadStatus::disconnected,
            0, why},
           sent_ns_);
    return;
  }
  deadline_ns_ = sent_ns_ + std::chrono::nanoseconds(config_.endpoint.response_timeout).count();
  // The answers wake the loop as they come, even while other devices keep it passing by: read at
  // their passes instead, a poll's newest sample would wait up to a read period for its publishing
  // (p99 above 1 ms, issue 45); one wake-up a poll is what that costs.
  set_schedule(drivers::ReadSchedule::per_arrival);
}

void MicrometerDriver::answer(modbus::ReadResult result, std::int64_t t_answer_ns) {
  for (std::size_t i = answered_; i < asked_; ++i) {
    xs_[i].result = result;
    xs_[i].t_answer_ns = t_answer_ns;
  }
  answered_ = asked_;
  all_answered();
}

void MicrometerDriver::all_answered() {
  ask_ = Ask::idle;
  continue_poll();
}

void MicrometerDriver::finish_poll() {
  poll_.reset();
  ask_ = Ask::idle;
  if (end_link_) {
    end_link(last_failure_);
    return;
  }
  // While other devices keep the loop passing by, the socket stays without readiness interest until
  // the next poll (no two epoll_ctl per poll): a stray answer is flushed when it starts, a hang-up is
  // reported all the same.
  set_schedule(busy_ ? drivers::ReadSchedule::paced : drivers::ReadSchedule::per_arrival);
  // Buffered mode reads what the amplifier stored meanwhile: a poll up to a fifth of a period early
  // (at another device's pass) costs nothing (its samples keep their own times) and spares a wake-up
  // of its own.
  if (config_.buffer) early_ns_ = std::min<std::int64_t>(poll_period().count() / 5, 2'000'000);
  set_service_slack(early_ns_);
  const std::int64_t now = mono_now_ns();
  next_poll_ns_ += poll_period().count();
  if (next_poll_ns_ < now) next_poll_ns_ = now;  // late: poll again at once (no catch-up burst)
}

void register_micrometer_driver(drivers::DriverRegistry& registry) {
  registry.add("micrometer-modbus", "inductance micrometer (gauge amplifier) over Modbus TCP or RTU, libmodbus",
               [](const drivers::DeviceConfig& c) -> std::unique_ptr<drivers::Driver> {
                 MicrometerConfig m = parse_micrometer_config(c.table);
                 // Buffered: the amplifier's own sampling rate; polled: one sample per poll.
                 const std::size_t ring = c.ring_for(m.buffer ? m.buffer->sample_rate_hz : m.poll_hz);
                 return std::make_unique<MicrometerDriver>(c.name, std::move(m), ring);
               });
}

}  // namespace guideway::drivers::micrometer
