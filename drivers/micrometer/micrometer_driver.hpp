#pragma once
// Driver "micrometer-modbus": reads an inductance gauge amplifier over Modbus TCP or RTU.
// Polled mode (default): one read of the [registers] block per poll, one displacement sample
// (metres) per answer. Buffered mode ([buffer] table): the amplifier keeps its recent samples in a
// ring of registers with a sample counter; every poll_period_ms the driver reads the counter and
// the new part of the ring, publishes every sample once, timestamped from its sample number, and
// counts what the ring lost between polls. Over TCP the counter read and the reads of the ring's new
// part (as far as the amplifier will have got, from its rate) go out in one write, so a poll is one
// round trip; an amplifier that answers only the first of such pipelined requests is read one
// request at a time from then on. Register maps, transport and rates come from the
// [[device]] table (docs/protocols.md). The driver is its protocol on the skeleton
// (drivers/loop_driver.hpp), over either transport: a poll is written once, as a coroutine that asks
// for each register read and is resumed with its answer. Over TCP the I/O loop does the reads (a
// non-blocking Modbus TCP client, modbus_tcp.hpp); over RTU the line's own thread does them with
// libmodbus, which blocks for a serial round trip, and answers through an eventfd the loop watches
// (modbus/rtu_line.hpp): the loop never waits for the line. Either way `streaming` while samples
// arrive within lost_after_failures polls. Thread safety as drivers::Driver.

#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "drivers/loop_driver.hpp"
#include "drivers/modbus/modbus_client.hpp"
#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/rtu_line.hpp"
#include "drivers/modbus/sample_ring.hpp"

namespace guideway::drivers::micrometer {

// Buffered mode's default poll period: favours CPU over latency (docs/protocols.md, "Buffered acquisition").
inline constexpr double default_buffer_poll_period_ms = 5.0;

struct MicrometerConfig {
  modbus::ModbusEndpoint endpoint;
  modbus::RegisterMap map;                                // polled mode
  double poll_hz = 50.0;                                  // polled mode
  std::optional<modbus::SampleRingMap> buffer;            // set: buffered mode
  double poll_period_ms = default_buffer_poll_period_ms;  // buffered mode
  int lost_after_failures = 3;                            // consecutive failed polls before the link is declared lost
  drivers::Reconnect reconnect{Backoff{0.1, 5.0}, {}};  // reconnect_min_ms 100, reconnect_max_ms 5000
};

// Reads every key the driver accepts (throws ConfigError naming file:line:key).
MicrometerConfig parse_micrometer_config(const TableReader& table);

class MicrometerDriver : public drivers::LoopDriver {
 public:
  MicrometerDriver(std::string name, MicrometerConfig config, std::size_t ring_capacity);
  ~MicrometerDriver() override;
  [[nodiscard]] const MicrometerConfig& config() const noexcept { return config_; }
  // Failed polls answered with a Modbus exception (also counted in bad_frames).
  [[nodiscard]] std::uint64_t exceptions() const noexcept { return exceptions_.load(std::memory_order_relaxed); }
  // Buffered mode: polls that found samples overwritten by the amplifier's ring (once per poll, however
  // many of its reads saw it), and the samples lost so
  // (also skipped sequence numbers: the pipeline's seq_gaps); counter resets (amplifier restarted).
  [[nodiscard]] std::uint64_t ring_overruns() const noexcept { return ring_overruns_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t lost_samples() const noexcept { return lost_samples_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::uint64_t counter_resets() const noexcept {
    return counter_resets_.load(std::memory_order_relaxed);
  }
  // exceptions, ring_overruns, lost_samples, counter_resets (the last three stay 0 in polled mode).
  [[nodiscard]] std::vector<drivers::NamedCounter> driver_counters() const override {
    const std::uint64_t lost = lost_samples_.load(std::memory_order_acquire);  // before the overruns: see lose()
    return {{"exceptions", exceptions()},
            {"ring_overruns", ring_overruns()},
            {"lost_samples", lost},
            {"counter_resets", counter_resets()},
            {"stale_answers", stale_answers_.load(std::memory_order_relaxed)}};
  }

 protected:
  // Connects to the TCP server without blocking, or opens the serial line (which does not block).
  void open() override;
  void on_link_up(std::int64_t now_ns) override;
  // Reads the answers (and drives the poll on with them); late or stray ones while idle are dropped.
  drivers::ReadOutcome read_some(bool at_others_pass) override;
  // Starts a poll when it is due, fails an ask that timed out (TCP; the RTU line times out its reads).
  std::int64_t service(std::int64_t now_ns) override;
  // A poll under way is finished first: what the amplifier answered is published.
  void on_stop() override;
  void on_link_down() override;

 private:
  struct RingCursor;
  class PollTask;
  // One register read a poll asks for, and its answer (put there by whoever does the I/O).
  using Exchange = modbus::RegisterRead;
  struct ReadAwaiter;
  ReadAwaiter ask(modbus::RegisterFunction function, std::uint16_t address, std::uint16_t count) noexcept;
  // The first n exchanges of xs_ (filled by the poll) asked at once; resumed when all are answered
  // (a failure fails the ones after it that have no answer).
  ReadAwaiter ask_all(std::size_t n) noexcept;
  // Most ring reads a buffered poll sends ahead with its counter read (3 x 41 samples at the
  // default record: 12 ms at 10 kHz); the rest, after an outage, are asked one by one.
  static constexpr std::size_t max_reads_ahead = 3;
  // One poll of either mode; sets end_link_ when the link is to be given up (last_failure_ says why).
  PollTask polled_poll();
  PollTask buffered_poll();
  PollTask make_poll();
  // The answer to a counter read sent at t_query: the sample numbering, restarts, the rate check.
  bool take_counter(const Exchange& x, std::int64_t t_query);
  // A failed request of either mode: counted (timeout, bad frame, exception; a lost link is not a
  // frame), and the reason to report.
  std::string count_failure(const modbus::ReadResult& r);
  void failed(const modbus::ReadResult& r);  // a poll's failed request: counted, the poll ends
  void lose(std::uint64_t n) noexcept;
  // Takes the late answers the RTU line discarded since the last call (`total` so far) into the counters.
  void count_stale(std::uint64_t total) noexcept;
  void count_stale_frames(std::uint64_t n) noexcept;
  // A new connection: the poll state starts afresh (the ring cursor is kept across reconnects).
  void new_link(bool relinked);
  [[nodiscard]] std::chrono::nanoseconds poll_period() const noexcept;

  [[nodiscard]] bool rtu() const noexcept { return config_.endpoint.kind == modbus::ModbusEndpoint::Kind::rtu; }

  // On the I/O loop (the loop thread's).
  enum class Ask { idle, awaiting };
  void start_poll();
  // Runs the poll until it asks for an answer that is not there yet, or ends.
  void continue_poll();
  void send_request();
  // The exchanges not answered yet all end with `result` (a timeout, a lost link, a bad frame).
  void answer(modbus::ReadResult result, std::int64_t t_answer_ns);
  void all_answered();
  void finish_poll();
  // Reads what the socket holds (the bytes read); `ended` says why the connection ended.
  std::size_t read_socket(std::string& ended);
  // Takes the answers rx_ holds, in the order asked.
  void take_answers();

  MicrometerConfig config_;
  std::atomic<std::uint64_t> exceptions_{0};
  std::atomic<std::uint64_t> ring_overruns_{0};
  std::atomic<std::uint64_t> lost_samples_{0};
  std::atomic<std::uint64_t> counter_resets_{0};
  std::atomic<std::uint64_t> stale_answers_{0};  // late answers discarded before a read (also bad frames)
  std::uint64_t stale_seen_ = 0;                 // the RTU line's count already taken
  // The poll's state (the loop thread's): the exchanges of the current ask (asked_ of them; a single
  // ask uses xs_[0]). Over RTU the line's thread writes their answers while the ask awaits them.
  std::vector<Exchange> xs_ = std::vector<Exchange>(1 + max_reads_ahead);
  std::size_t asked_ = 1;
  std::unique_ptr<RingCursor> cursor_;  // buffered mode
  std::vector<modbus::Reading> readings_;
  bool gap_ = false;  // polled mode: the next sample follows a reconnect or a failed poll
  int failures_ = 0;
  bool link_gone_ = false;
  bool end_link_ = false;
  std::string last_failure_;
  Ask ask_ = Ask::idle;
  std::int64_t deadline_ns_ = 0;  // awaiting: the timeout (TCP; never over RTU)
  std::int64_t next_poll_ns_ = 0;
  std::int64_t early_ns_ = 0;  // idle: how early the next poll may start (at another device's pass)
  std::int64_t sent_ns_ = 0;
  std::uint16_t transaction_ = 0;  // the last one sent; the ask's first is transaction_ - asked_ + 1
  std::size_t answered_ = 0;       // exchanges of the ask answered so far
  std::int64_t rx_ns_ = 0;         // when the bytes in rx_ arrived (the kernel's receive time)
  int partly_answered_ = 0;        // pipelined asks in a row that timed out with some answered
  bool one_at_a_time_ = false;     // the amplifier dropped pipelined requests: ask one by one
  std::vector<std::uint8_t> rx_;
  std::unique_ptr<PollTask> poll_;
  std::uint64_t poll_pass_ = 0;  // the loop's pass when the last poll began
  bool busy_ = false;            // other devices keep the loop passing by: no readiness interest between polls
  // RTU: the serial line, kept across links (a line reopened is the same bus); the next ask first
  // discards what the line holds (the first of a poll).
  std::unique_ptr<modbus::RtuLine> rtu_;
  bool flush_next_ = false;
};

void register_micrometer_driver(drivers::DriverRegistry& registry);

}  // namespace guideway::drivers::micrometer
