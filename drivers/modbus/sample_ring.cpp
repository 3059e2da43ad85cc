// A gauge amplifier's sample buffer read over Modbus (sample_ring.hpp): the ring of registers and its counter, new
// samples found.
#include "drivers/modbus/sample_ring.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

namespace guideway::drivers::modbus {

namespace {

constexpr std::uint64_t two32 = std::uint64_t{1} << 32;

}  // namespace

std::string SampleRingMap::validate() const {
  if (const std::string why = record.validate(); !why.empty()) return why;
  if (record.value_address != 0) return "the value must be the first register of a slot";
  if (record.status_address && *record.status_address != register_count(record.value_type)) {
    return "the status must follow the value in a slot";
  }
  if (ring_samples < 1 || ring_samples > 65535) return "ring_samples must be in [1, 65535]";
  if (std::uint32_t{ring_address} + ring_registers() > 0x10000) return "ring beyond register 65535";
  if (std::uint32_t{counter_address} + 2 > 0x10000) return "counter beyond register 65535";
  const std::uint32_t ring_end = std::uint32_t{ring_address} + ring_registers();
  if (std::uint32_t{counter_address} + 2 > ring_address && counter_address < ring_end) {
    return "counter registers overlap the ring";
  }
  if (!std::isfinite(sample_rate_hz) || sample_rate_hz < 1e-3 || sample_rate_hz > 1e6) {
    return "sample_rate_hz must be in [0.001, 1e6]";
  }
  return {};
}

SampleRingMap parse_sample_ring(const TableReader& t) {
  SampleRingMap m;
  m.function = t.get_choice("function", "input", {"input", "holding"}) == "holding" ? RegisterFunction::holding
                                                                                    : RegisterFunction::input;
  m.counter_address = static_cast<std::uint16_t>(t.require_int("counter_address", 0, 65534));
  m.counter_word_order =
      t.get_choice("counter_word_order", "big", {"big", "little"}) == "little" ? WordOrder::little : WordOrder::big;
  m.ring_address = static_cast<std::uint16_t>(t.require_int("ring_address", 0, 65535));
  m.ring_samples = static_cast<std::uint32_t>(t.require_int("ring_samples", 1, 65535));
  m.sample_rate_hz = t.require_double("sample_rate_hz", 1e-3, 1e6);
  RegisterMap& r = m.record;
  r.value_address = 0;
  r.value_type =
      *value_type_from_string(t.get_choice("value_type", "int32", {"int16", "uint16", "int32", "uint32", "float32"}));
  r.word_order = t.get_choice("word_order", "big", {"big", "little"}) == "little" ? WordOrder::little : WordOrder::big;
  r.scale_um = t.get_double("scale_um", 0.01);
  r.offset_um = t.get_double("offset_um", 0.0);
  r.status_address = t.get_bool("status", true) ? std::optional<std::uint16_t>(register_count(r.value_type))
                                                : std::nullopt;
  r.out_of_range_mask = static_cast<std::uint16_t>(t.get_int("out_of_range_mask", 0x0001, 0, 0xffff));
  r.probe_missing_mask = static_cast<std::uint16_t>(t.get_int("probe_missing_mask", 0x0002, 0, 0xffff));
  if (const std::string why = r.validate(); !why.empty()) t.fail("scale_um", why);
  if (std::uint32_t{m.ring_address} + m.ring_registers() > 0x10000) {
    t.fail("ring_samples", std::to_string(m.ring_samples) + " slots of " + std::to_string(m.record_registers()) +
                               " registers from " + std::to_string(m.ring_address) + " go beyond register 65535");
  }
  if (const std::string why = m.validate(); !why.empty()) t.fail("counter_address", why);
  return m;
}

std::uint32_t decode_counter(const SampleRingMap& map, std::uint16_t first, std::uint16_t second) noexcept {
  return map.counter_word_order == WordOrder::big ? (std::uint32_t{first} << 16) | second
                                                  : (std::uint32_t{second} << 16) | first;
}

std::array<std::uint16_t, 2> encode_counter(const SampleRingMap& map, std::uint32_t counter) noexcept {
  const auto hi = static_cast<std::uint16_t>(counter >> 16);
  const auto lo = static_cast<std::uint16_t>(counter & 0xffff);
  return map.counter_word_order == WordOrder::big ? std::array<std::uint16_t, 2>{hi, lo}
                                                  : std::array<std::uint16_t, 2>{lo, hi};
}

std::uint64_t oldest_intact(const SampleRingMap& map, std::uint64_t count_read) noexcept {
  // The amplifier may be writing sample count_read into its slot (write, then increment): treat it
  // as taken, so the ring holds ring_samples - 1 stable samples.
  const std::uint64_t count = count_read + 1;
  const std::uint64_t n = map.ring_samples;
  const std::uint64_t lo = count > n ? count - n : 0;
  const std::uint64_t wrap = count & ~(two32 - 1);  // where the 32-bit counter last wrapped
  if (wrap <= lo || std::has_single_bit(n)) return std::min(lo, count_read);
  // The m samples after the wrap went to slots 0..m-1: a sample before it in one of those is gone.
  const std::uint64_t m = count - wrap;
  for (std::uint64_t u = wrap; u > lo; --u) {
    if (ring_slot(map, u - 1) < m) return std::min(u, count_read);
  }
  return std::min(lo, count_read);
}

std::vector<RingRead> plan_ring_reads(const SampleRingMap& map, std::uint64_t first, std::uint64_t end) {
  std::vector<RingRead> out;
  if (!map.validate().empty() || end < first || end - first > map.ring_samples) return out;
  const std::uint32_t rec = map.record_registers();
  for (std::uint64_t u = first; u < end;) {
    const std::uint32_t slot = ring_slot(map, u);
    std::uint64_t n = std::min<std::uint64_t>(end - u, map.ring_samples - slot);
    n = std::min<std::uint64_t>(n, two32 - static_cast<std::uint32_t>(u));  // slots restart at 0 on a counter wrap
    n = std::min<std::uint64_t>(n, map.samples_per_request());
    out.push_back({static_cast<std::uint16_t>(map.ring_address + slot * rec), static_cast<std::uint16_t>(n * rec), u,
                   static_cast<std::uint32_t>(n)});
    u += n;
  }
  return out;
}

bool decode_ring_block(const SampleRingMap& map, const RingRead& read, std::span<const std::uint16_t> block,
                       std::span<Reading> out) noexcept {
  const std::size_t rec = map.record_registers();
  if (!map.validate().empty() || block.size() < std::size_t{read.samples} * rec || out.size() < read.samples) {
    return false;
  }
  for (std::size_t i = 0; i < read.samples; ++i) out[i] = decode_registers(map.record, block.subspan(i * rec, rec));
  return true;
}

CounterTracker::Step CounterTracker::update(std::uint32_t counter, double elapsed_s, double rate_hz) noexcept {
  if (!started_) {
    started_ = true;
    count_ = counter;
    return Step::first;
  }
  const std::uint32_t diff = counter - static_cast<std::uint32_t>(count_);
  const double most = rate_hz * std::max(0.0, elapsed_s) * 1.05 + 2.0;
  if (diff >= 0x80000000u || static_cast<double>(diff) > most) {
    count_ = (((count_ >> 32) + 1) << 32) | counter;
    return Step::reset;
  }
  count_ += diff;
  return Step::advanced;
}

void TimeAnchor::reset(std::uint64_t base) noexcept {
  base_ = base;
  bounds_.clear();
  first_.reset();
}

void TimeAnchor::observe(std::int64_t t_answer_ns, std::uint64_t count) {
  if (count <= base_) return;  // no sample taken since the base: nothing bounds the anchor yet
  const auto samples = static_cast<double>(count - 1 - base_);
  const double anchor = static_cast<double>(t_answer_ns) - samples * 1e9 / rate_hz_;
  while (!bounds_.empty() && bounds_.back().anchor_ns >= anchor) bounds_.pop_back();
  bounds_.push_back({t_answer_ns, anchor, samples});
  while (bounds_.front().t_ns < t_answer_ns - window_ns_) bounds_.pop_front();
  if (!first_) t_first_ns_ = t_answer_ns;
  if (t_answer_ns - t_first_ns_ <= window_ns_ && (!first_ || anchor < first_->anchor_ns)) {
    first_ = Bound{t_answer_ns, anchor, samples};
  }
  t_last_ns_ = t_answer_ns;
}

std::optional<double> TimeAnchor::rate_error() const noexcept {
  if (!first_ || bounds_.empty() || t_last_ns_ - t_first_ns_ < rate_span_ns) return std::nullopt;
  const Bound& now = bounds_.front();
  if (now.samples <= first_->samples) return std::nullopt;
  // anchor(c) = t0 + c (1/true - 1/nominal) + delay: the slope gives nominal/true - 1.
  const double slope = (now.anchor_ns - first_->anchor_ns) * 1e-9 * rate_hz_ / (now.samples - first_->samples);
  return 1.0 / (1.0 + slope) - 1.0;
}

std::int64_t TimeAnchor::time_ns(std::uint64_t k) const noexcept {
  const double offset = (static_cast<double>(k) - static_cast<double>(base_)) * 1e9 / rate_hz_;
  return std::llround(bounds_.front().anchor_ns + offset);
}

std::int64_t StampSequencer::stamp(std::uint64_t k, std::int64_t anchor_time_ns) noexcept {
  std::int64_t t = anchor_time_ns;
  if (last_t_ns_ != std::numeric_limits<std::int64_t>::min()) {
    std::int64_t least = last_t_ns_ + 1;
    if (have_k_ && k > last_k_ && k - last_k_ < (std::uint64_t{1} << 32)) {
      least = std::max<std::int64_t>(least, last_t_ns_ + std::llround(static_cast<double>(k - last_k_) * half_period_ns_));
    }
    t = std::max(t, least);
  }
  have_k_ = true;
  last_k_ = k;
  last_t_ns_ = t;
  return t;
}

}  // namespace guideway::drivers::modbus
