#include "drivers/micrometer/micrometer_driver.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

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
    if (t.has("poll_period_ms")) t.fail("poll_period_ms", "only in buffered mode ([device.buffer]); polled mode uses poll_hz");
    c.poll_hz = t.get_double("poll_hz", 50.0, 0.01, 10000.0);
  }
  c.lost_after_failures = static_cast<int>(t.get_int("lost_after_failures", 3, 1, 1000));
  c.backoff_initial = std::chrono::milliseconds(t.get_int("backoff_initial_ms", 100, 1, 600000));
  c.backoff_max = std::chrono::milliseconds(t.get_int("backoff_max_ms", 5000, 1, 3600000));
  if (c.backoff_max < c.backoff_initial) t.fail("backoff_max_ms", "must not be less than backoff_initial_ms");
  return c;
}

// Where buffered mode stands; kept across reconnects, so samples taken during a short outage are
// fetched from the amplifier's ring afterwards.
struct MicrometerDriver::RingCursor {
  // A 0.2 s anchor window: a device slow by up to the rate tolerance makes stamps early by at most
  // 0.2 s x 0.5 % = 1 ms; beyond it the state says so.
  explicit RingCursor(double rate_hz) : anchor(rate_hz, 200'000'000), stamps(rate_hz) {}
  modbus::CounterTracker counter;
  modbus::TimeAnchor anchor;   // sample number -> CLOCK_MONOTONIC, from the last 0.2 s of counter reads
  std::uint64_t next = 0;      // the next sample number to publish
  std::int64_t last_query_ns = 0;  // when the last good counter read was sent
  modbus::StampSequencer stamps;  // published timestamps only increase, by >= half a period a sample
  bool gap = false;            // the next published sample follows lost ones
  int resets_in_row = 0;       // counter reads in a row that looked like an amplifier restart
  bool rate_flagged = false;   // the measured rate is off sample_rate_hz by more than the tolerance
  bool overrun_counted = false;  // this poll already counted its ring overrun
};

namespace {
// How far the amplifier's measured rate may be off sample_rate_hz before the state says so.
constexpr double rate_tolerance = 0.005;
}  // namespace

MicrometerDriver::MicrometerDriver(std::string name, MicrometerConfig config, std::size_t ring_capacity)
    : Driver(std::move(name), "micrometer-modbus", {{"displacement", "m"}}, ring_capacity),
      config_(std::move(config)) {}

MicrometerDriver::~MicrometerDriver() { stop(); }

void MicrometerDriver::run(std::stop_token stop) {
  modbus::ModbusClient client(config_.endpoint);
  stale_seen_ = 0;  // a new client counts from 0
  auto backoff = config_.backoff_initial;
  bool ever_connected = false;
  bool gap = false;  // polled mode: the next sample follows a reconnect or a failed poll
  RingCursor cursor(config_.buffer ? config_.buffer->sample_rate_hz : 1.0);

  while (!stop.stop_requested()) {
    set_state(drivers::DeviceState::connecting);
    std::string error;
    if (!client.connect(error)) {
      set_state(drivers::DeviceState::lost, error);
      if (!sleep_for(stop, backoff)) break;
      backoff = std::min(backoff * 2, config_.backoff_max);
      continue;
    }
    if (ever_connected) {
      reconnects_.fetch_add(1, std::memory_order_relaxed);
      gap = true;
    }
    ever_connected = true;
    set_state(drivers::DeviceState::streaming);
    const std::string last_failure = config_.buffer ? stream_buffered(stop, client, backoff, cursor)
                                                    : stream_polled(stop, client, backoff, gap);
    client.close();
    if (stop.stop_requested()) break;
    set_state(drivers::DeviceState::lost, last_failure);
    if (!sleep_for(stop, backoff)) break;
    backoff = std::min(backoff * 2, config_.backoff_max);
  }
}

std::string MicrometerDriver::stream_polled(const std::stop_token& stop, modbus::ModbusClient& client,
                                            std::chrono::milliseconds& backoff, bool& gap) {
  const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / config_.poll_hz));
  const std::uint16_t start = config_.map.block_start();
  const std::uint16_t count = config_.map.block_count();
  std::vector<std::uint16_t> block(count);
  int failures = 0;
  std::string last_failure;
  auto next = std::chrono::steady_clock::now();
  while (!stop.stop_requested()) {
    client.flush();  // stray or duplicated answers must not be taken for the next one
    const modbus::ReadResult r = client.read(config_.map.function, start, count, block);
    count_stale(client);
    const std::int64_t t = mono_now_ns();
    if (r.status == modbus::ReadStatus::ok) {
      frames_.fetch_add(1, std::memory_order_relaxed);
      const modbus::Reading reading = modbus::decode_registers(config_.map, block);
      Sample s;
      s.t_mono_ns = t;
      s.value_count = 1;
      s.value[0] = reading.value_m;
      s.flags = reading.flags | (gap ? sample_after_gap : 0u);
      publish(s);
      gap = false;
      failures = 0;
      backoff = config_.backoff_initial;
    } else if (r.status == modbus::ReadStatus::disconnected) {
      last_failure = count_failure(r);
      failures = config_.lost_after_failures;
    } else {
      last_failure = count_failure(r);
      ++failures;
      gap = true;
    }
    if (failures >= config_.lost_after_failures) break;
    next += period;
    const auto now = std::chrono::steady_clock::now();
    if (next < now) next = now;  // late (a timeout ate the period): poll again at once, no catch-up burst
    if (!sleep_for(stop, next - now)) break;
  }
  return last_failure;
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

void MicrometerDriver::count_stale(const modbus::ModbusClient& client) noexcept {
  const std::uint64_t n = client.stale_answers();
  if (n == stale_seen_) return;
  bad_frames_.fetch_add(n - stale_seen_, std::memory_order_relaxed);
  stale_answers_.fetch_add(n - stale_seen_, std::memory_order_relaxed);
  stale_seen_ = n;
}

void MicrometerDriver::lose(RingCursor& cursor, std::uint64_t n) noexcept {
  if (n == 0) return;
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

std::string MicrometerDriver::stream_buffered(const std::stop_token& stop, modbus::ModbusClient& client,
                                              std::chrono::milliseconds& backoff, RingCursor& cursor) {
  const modbus::SampleRingMap& ring = *config_.buffer;
  const double rate = ring.sample_rate_hz;
  const auto period = std::chrono::nanoseconds(static_cast<std::int64_t>(config_.poll_period_ms * 1e6));
  std::vector<std::uint16_t> block(125);
  std::vector<modbus::Reading> readings(ring.samples_per_request());
  int failures = 0;
  std::string last_failure;
  bool link_gone = false;
  // One failed request: counted, and the poll ends (the next poll asks again: reads are idempotent).
  auto failed = [&](const modbus::ReadResult& r) {
    last_failure = count_failure(r);
    if (r.status == modbus::ReadStatus::disconnected) {
      link_gone = true;
    } else {
      ++failures;
    }
  };
  // Reads the counter; false when the request failed. Handles the first read and device restarts.
  auto read_counter = [&]() -> bool {
    const std::int64_t t_query = mono_now_ns();
    const modbus::ReadResult r = client.read(ring.function, ring.counter_address, 2, block);
    count_stale(client);
    const std::int64_t t_answer = mono_now_ns();
    if (r.status != modbus::ReadStatus::ok) {
      failed(r);
      return false;
    }
    frames_.fetch_add(1, std::memory_order_relaxed);
    const double elapsed_s = static_cast<double>(t_answer - cursor.last_query_ns) * 1e-9;
    const std::uint32_t counter = modbus::decode_counter(ring, block[0], block[1]);
    const bool backwards = cursor.counter.started() &&
                           counter - static_cast<std::uint32_t>(cursor.counter.count()) >= 0x80000000u;
    const auto step = cursor.counter.update(counter, elapsed_s, rate);
    cursor.last_query_ns = t_query;
    const std::uint64_t count = cursor.counter.count();
    if (step == modbus::CounterTracker::Step::advanced && cursor.resets_in_row > 0) {
      if (cursor.resets_in_row >= 3) set_state(drivers::DeviceState::streaming);
      cursor.resets_in_row = 0;
    }
    if (step != modbus::CounterTracker::Step::advanced) {
      // Start at the newest sample (first read), or after a restart of the amplifier: what it took
      // before the restart is not in this count, so it cannot be fetched or numbered; the next sample says so.
      if (step == modbus::CounterTracker::Step::reset) {
        counter_resets_.fetch_add(1, std::memory_order_relaxed);
        cursor.gap = true;
        // A restart now and then is an amplifier; one at every poll is a counter running faster
        // than the configured rate, and nothing would ever be published: say so, again after every
        // further one (a reconnect sets the state to streaming; the count survives it).
        if (++cursor.resets_in_row >= 3) {
          std::string why = "the sample counter runs faster than sample_rate_hz = ";
          append_shortest(why, rate);
          set_state(drivers::DeviceState::error, why + " (or the amplifier keeps restarting): check [device.buffer]");
        }
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
  };

  auto wake = std::chrono::steady_clock::now();
  while (!stop.stop_requested()) {
    client.flush();  // a late answer to a failed request must not be taken for this one
    cursor.overrun_counted = false;
    bool ok = read_counter();
    if (ok) {
      const std::uint64_t count = cursor.counter.count();
      if (const std::uint64_t oldest = modbus::oldest_intact(ring, count); cursor.next < oldest) {
        lose(cursor, oldest - cursor.next);  // the ring lapped since the last poll
        cursor.next = oldest;
      }
      const std::int64_t t_counter = cursor.last_query_ns;
      for (const modbus::RingRead& rr : modbus::plan_ring_reads(ring, cursor.next, count)) {
        const modbus::ReadResult r = client.read(ring.function, rr.address, rr.count, block);
        count_stale(client);
        if (r.status != modbus::ReadStatus::ok) {
          failed(r);
          ok = false;
          break;
        }
        frames_.fetch_add(1, std::memory_order_relaxed);
        modbus::decode_ring_block(ring, rr, block, readings);
        // Samples near the ring's tail may have been overwritten while the requests were under way:
        // bound how far the amplifier can have got, and when that reaches them, ask it.
        std::uint64_t first = rr.first;
        const double since_s = static_cast<double>(mono_now_ns() - t_counter) * 1e-9;
        const auto could = count + static_cast<std::uint64_t>(rate * since_s * 1.05 + 2.0);
        if (modbus::oldest_intact(ring, could) > first) {
          if (!read_counter()) {
            ok = false;
            break;
          }
          const std::uint64_t intact = modbus::oldest_intact(ring, cursor.counter.count());
          if (cursor.next != rr.first) break;  // the amplifier restarted: start again at the next poll
          if (intact > first) {
            lose(cursor, std::min<std::uint64_t>(intact, rr.first + rr.samples) - first);
            first = std::min<std::uint64_t>(intact, rr.first + rr.samples);
          }
        }
        for (std::uint64_t k = first; k < rr.first + rr.samples; ++k) {
          const modbus::Reading& reading = readings[k - rr.first];
          Sample s;
          s.t_mono_ns = cursor.stamps.stamp(k, cursor.anchor.time_ns(k));
          s.value_count = 1;
          s.value[0] = reading.value_m;
          s.flags = reading.flags | (cursor.gap ? sample_after_gap : 0u);
          cursor.gap = false;
          publish(s);
        }
        cursor.next = rr.first + rr.samples;
      }
    }
    if (link_gone || failures >= config_.lost_after_failures) break;
    if (ok) {
      failures = 0;
      backoff = config_.backoff_initial;
    }
    wake += period;
    const auto now = std::chrono::steady_clock::now();
    if (wake < now) wake = now;  // late: poll again at once (the ring holds what arrived meanwhile)
    if (!sleep_for(stop, wake - now)) break;
  }
  return last_failure;
}

void register_micrometer_driver(drivers::DriverRegistry& registry) {
  registry.add("micrometer-modbus", "inductance micrometer (gauge amplifier) over Modbus TCP or RTU, libmodbus",
               [](const drivers::DeviceConfig& c) -> std::unique_ptr<drivers::Driver> {
                 return std::make_unique<MicrometerDriver>(c.name, parse_micrometer_config(c.table), c.ring_capacity);
               });
}

}  // namespace guideway::drivers::micrometer
