#pragma once
// A gauge amplifier's (or Modbus data logger's) sample buffer: a ring of registers holding the most
// recent samples and a 32-bit counter of the samples taken, described in configuration so a real
// device is mapped without code (docs/protocols.md, "Buffered acquisition"). Everything here is pure
// (no I/O, thread safe) so it can be fuzzed; the driver does the reads.
//
// Convention: sample number k (the counter's value just before the sample was taken, modulo 2^32)
// sits in ring slot k mod ring_samples; the counter is incremented after the slot is written. With a
// power-of-two ring that is the same as a free-running write pointer.

#include <array>
#include <cstdint>
#include <deque>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/toml_access.hpp"
#include "drivers/modbus/register_map.hpp"

namespace guideway::drivers::modbus {

struct SampleRingMap {
  RegisterFunction function = RegisterFunction::input;  // both counter and ring are read with it
  std::uint16_t counter_address = 100;                  // uint32 total samples taken, two registers
  WordOrder counter_word_order = WordOrder::big;
  std::uint16_t ring_address = 200;  // first register of slot 0
  std::uint32_t ring_samples = 4096;
  double sample_rate_hz = 10000.0;  // the device's sampling rate (its own clock)
  // One slot: the value at register 0 of the slot, then (when record.status_address is set) a
  // status word right after it; value type, word order, scale, offset and masks as in a RegisterMap
  // (the default: int32 high word first in 10 nm counts, status at register 2 of the slot).
  RegisterMap record;

  [[nodiscard]] std::uint16_t record_registers() const noexcept { return record.block_count(); }
  [[nodiscard]] std::uint32_t ring_registers() const noexcept { return ring_samples * record_registers(); }
  // Largest number of samples one read request (125 registers) carries.
  [[nodiscard]] std::uint32_t samples_per_request() const noexcept { return 125u / record_registers(); }
  // Empty when valid, else why not.
  [[nodiscard]] std::string validate() const;
};

// Reads a [device.buffer] table. Throws ConfigError with file:line:key.
SampleRingMap parse_sample_ring(const TableReader& table);

// The counter from its two registers (the map's counter word order).
[[nodiscard]] std::uint32_t decode_counter(const SampleRingMap& map, std::uint16_t first, std::uint16_t second) noexcept;
// And back, for emulators: {first register, second register}.
[[nodiscard]] std::array<std::uint16_t, 2> encode_counter(const SampleRingMap& map, std::uint32_t counter) noexcept;

// The slot of the sample with unwrapped (64-bit) number k.
[[nodiscard]] inline std::uint32_t ring_slot(const SampleRingMap& map, std::uint64_t k) noexcept {
  return static_cast<std::uint32_t>(k) % map.ring_samples;
}

// Samples [first, end) still intact in the ring when the device has taken `count` samples (count >=
// end): the first of them not yet overwritten, nor being overwritten by sample `count` (the ring
// holds ring_samples - 1 stable samples). Handles the slot discontinuity a non-power-of-two
// ring has where the 32-bit counter wraps.
[[nodiscard]] std::uint64_t oldest_intact(const SampleRingMap& map, std::uint64_t count) noexcept;

// One read request of part of the ring: `samples` consecutive samples starting with number `first`.
struct RingRead {
  std::uint16_t address = 0;
  std::uint16_t count = 0;  // registers
  std::uint64_t first = 0;
  std::uint32_t samples = 0;
};
// The fewest requests (<= 125 registers each, split where the ring wraps) covering [first, end).
std::vector<RingRead> plan_ring_reads(const SampleRingMap& map, std::uint64_t first, std::uint64_t end);

// Decodes the samples of one block read as `read` describes. `out` receives read.samples readings;
// returns false (and leaves out untouched) when the block is too short or the map invalid. Never throws.
bool decode_ring_block(const SampleRingMap& map, const RingRead& read, std::span<const std::uint16_t> block,
                       std::span<Reading> out) noexcept;

// Unwraps the 32-bit counter into a 64-bit sample number and spots a device that restarted.
class CounterTracker {
 public:
  enum class Step { first, advanced, reset };
  // counter: as read; elapsed_s: since the previous good read; rate_hz: nominal device rate.
  // A counter that went backwards, or advanced more than the device can have sampled in elapsed_s
  // (+5 % and 2 samples), is a reset: the count restarts in a new 2^32 epoch above the previous one.
  Step update(std::uint32_t counter, double elapsed_s, double rate_hz) noexcept;
  [[nodiscard]] std::uint64_t count() const noexcept { return count_; }
  [[nodiscard]] bool started() const noexcept { return started_; }

 private:
  bool started_ = false;
  std::uint64_t count_ = 0;
};

// Maps sample numbers to CLOCK_MONOTONIC. Each counter read tells that sample count-1 was taken no
// later than the answer arrived: anchor <= t_answer - (count - 1) / rate. The anchor is the smallest
// such bound over the polls of the last window_ns, so it is late by the quickest answer's delay in
// the window (the time from the newest sample to its answer). A device slower than rate_hz by a
// fraction e makes the bounds rise, and the oldest (smallest) one in the window makes stamps EARLY by
// up to e x window (faster: the newest bound is the smallest, early by e x the sample's age at that
// read, about e x a poll period): keep the window short, and watch rate_error().
class TimeAnchor {
 public:
  TimeAnchor(double rate_hz, std::int64_t window_ns) : rate_hz_(rate_hz), window_ns_(window_ns) {}
  void reset(std::uint64_t base) noexcept;
  // A counter read answered at t_answer_ns with count samples taken (count > base).
  void observe(std::int64_t t_answer_ns, std::uint64_t count);
  [[nodiscard]] bool ready() const noexcept { return !bounds_.empty(); }
  // When sample k was taken (ready() must be true).
  [[nodiscard]] std::int64_t time_ns(std::uint64_t k) const noexcept;
  // The device's real rate relative to rate_hz, minus 1 (-0.01: 1 % slow), from the drift of the
  // quickest answer's bound between the first window after reset() and the current one; nothing
  // until the two are rate_span_ns apart (then answer delays jittering by 1 ms err by 1e-3 at most).
  [[nodiscard]] std::optional<double> rate_error() const noexcept;
  static constexpr std::int64_t rate_span_ns = 1'000'000'000;

 private:
  double rate_hz_;
  std::int64_t window_ns_;
  std::uint64_t base_ = 0;  // sample numbers are measured from here (keeps the doubles small)
  struct Bound {
    std::int64_t t_ns;
    double anchor_ns;  // t_answer - (count - 1 - base) / rate
    double samples;    // count - 1 - base
  };
  std::deque<Bound> bounds_;  // a sliding-window minimum: anchors increasing from front to back
  std::optional<Bound> first_;  // the smallest bound in the first window after reset()
  std::int64_t t_first_ns_ = 0;
  std::int64_t t_last_ns_ = 0;
};

// Published timestamps from anchor times: strictly increasing, and when the anchor drops (a quicker
// answer) they approach it by at most half a period per sample instead of piling up 1 ns apart. Never
// earlier than the anchor's time, so never earlier than the anchor allows.
class StampSequencer {
 public:
  explicit StampSequencer(double rate_hz) : half_period_ns_(0.5e9 / rate_hz) {}
  // After a counter restart sample numbers jump: the next stamp only has to follow the last one.
  void restart() noexcept { have_k_ = false; }
  std::int64_t stamp(std::uint64_t k, std::int64_t anchor_time_ns) noexcept;

 private:
  double half_period_ns_;
  bool have_k_ = false;
  std::uint64_t last_k_ = 0;
  std::int64_t last_t_ns_ = std::numeric_limits<std::int64_t>::min();
};

}  // namespace guideway::drivers::modbus
