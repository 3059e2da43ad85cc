#pragma once
// One timestamped reading of a device: the element type of every driver ring.

#include <array>
#include <cstdint>

namespace guideway {

// Flag bits on a Sample. A flagged value is not a number to use: the instrument said why.
enum SampleFlag : std::uint32_t {
  sample_ok = 0,
  sample_out_of_range = 1u << 0,   // instrument reports its range exceeded
  sample_no_signal = 1u << 1,      // e.g. autocollimator: no reflection
  sample_partial = 1u << 2,        // some channels missing in this cycle (e.g. a PDO missed a SYNC)
  sample_after_gap = 1u << 3,      // first sample after a reconnect or a detected gap
};

inline constexpr std::size_t max_sample_values = 5;

// 64 bytes, one cache line. Values are SI (metres, radians, seconds) in the order of the
// driver's channel list.
struct Sample {
  std::uint64_t seq = 0;        // per-driver sequence number, +1 per sample produced (drops leave gaps)
  std::int64_t t_mono_ns = 0;   // CLOCK_MONOTONIC when the reading was taken/received
  std::uint32_t flags = 0;      // SampleFlag bits
  std::uint32_t value_count = 0;
  std::array<double, max_sample_values> value{};
};
static_assert(sizeof(Sample) == 64);

}  // namespace guideway
