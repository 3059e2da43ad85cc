#pragma once
// How many samples a device's ring holds: one rule for every device (docs/architecture.md, "Rings").
// A ring is where a device's samples wait until the pipeline takes them, and its slots (64 bytes a sample,
// written when the ring is made) are memory guidewayd holds for as long as it runs: each ring is sized to
// its own device, not to the fastest one.
//
// The rule: at least ring_hold_s of the device's full rate (the most it produces: a SYNC rate, a poll or
// sampling rate, points per second; each driver says which), rounded up to a power of two (an index is
// masked, not divided), never below min_ring_capacity.
// Why 8 s: the pipeline empties every ring at the end of each pass of the I/O thread, so a ring fills only
// while its consumer is held up and its producer is not (a driver on a thread of its own, a pass that
// reads a backlog); threads on a loaded controller PC stall for seconds (LinuxCNC's own servo thread was
// seen stalled 3 s, docs/linuxcnc.md): 8 s is that with margin. Why 1,024: a slow device still takes a
// burst beyond its rate (a backlog after a reconnect) for 64 KB.

#include <cstddef>

namespace guideway::drivers {

inline constexpr double ring_hold_s = 8.0;
inline constexpr std::size_t min_ring_capacity = 1024;
// The largest ring: what a configuration may give (ring_capacity), and the rule's cap (a device faster than
// 8 MHz gets less than ring_hold_s).
inline constexpr std::size_t max_ring_capacity = std::size_t{1} << 26;
// A device whose full rate guidewayd cannot know (a plugin's: its ABI does not say), unless its table gives one.
inline constexpr std::size_t unknown_rate_ring_capacity = 65536;

// The rule's capacity for a device whose full rate is full_rate_hz. Throws std::invalid_argument for a rate
// that is not a positive number.
std::size_t ring_capacity_for(double full_rate_hz);

}  // namespace guideway::drivers
