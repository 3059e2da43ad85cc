#pragma once
// The DBB bus protocol, CANopen encoder profile style (CiA 406): every SYNC (COB-ID 0x080) makes each
// encoder node transmit TPDO1 (COB-ID 0x180 + node) carrying its position value, object 0x6004,
// as a 32-bit little-endian count. Pure functions and a frame-by-frame decoder with no I/O, so the
// same code serves the driver, the emulator and the fuzz tests. Not thread safe (one decoder per bus).

#include <linux/can.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/sample.hpp"

namespace guideway::drivers::dbb {

inline constexpr std::uint32_t sync_cob_id = 0x080;
inline constexpr std::uint32_t emcy_cob_base = 0x080;   // EMCY: 0x080 + node (0x081..0x0FF)
inline constexpr std::uint32_t tpdo1_cob_base = 0x180;  // TPDO1: 0x180 + node
inline constexpr std::uint16_t position_value_index = 0x6004;
inline constexpr std::size_t max_encoders = max_sample_values;

// Scaling of one encoder node: position_m = offset_m + direction * resolution_m * (count - zero_count),
// where count is the 32-bit position value unwrapped to 64 bits (the first count is read as a
// signed 32-bit number, later ones continue across the 2^32 wrap).
struct EncoderScale {
  std::string channel;         // "bar_length", "x", "y", "z"
  std::uint8_t node_id = 1;    // 1..127
  double resolution_m = 1e-7;  // metres per count
  int direction = +1;          // +1 or -1
  std::int64_t zero_count = 0;
  double offset_m = 0.0;  // position at zero_count (the bar's nominal length for the bar encoder)
};

// Converts metres to the 32-bit count an encoder with this scale would send (the emulator's side).
std::uint32_t position_to_count(const EncoderScale& scale, double position_m) noexcept;
double count_to_position(const EncoderScale& scale, std::int64_t unwrapped_count) noexcept;

can_frame make_sync_frame() noexcept;
can_frame make_position_pdo(std::uint8_t node_id, std::uint32_t count) noexcept;

// What one frame is, independent of any state.
struct FrameInfo {
  enum class Kind {
    sync,         // SYNC (DLC 0, or 1 with a counter)
    position,     // TPDO1 with a 32-bit position value; node and count set
    error_frame,  // CAN_ERR_FLAG set; error_class = can_id & CAN_ERR_MASK
    emergency,    // EMCY from a node
    other,        // valid frame that is not ours (other COB-IDs, extended IDs, RTR)
    bad,          // malformed: a SYNC or TPDO1 with the wrong length, DLC > 8
  };
  Kind kind = Kind::other;
  std::uint8_t node = 0;
  std::uint32_t count = 0;
  std::uint32_t error_class = 0;
  const char* why = "";  // for bad frames
};
FrameInfo classify_frame(const can_frame& frame) noexcept;

// One SYNC cycle: the positions sampled at one SYNC, in the order of the configured encoders.
struct DbbCycle {
  std::int64_t t_sync_ns = 0;  // when the SYNC was seen (received, or sent by us)
  std::uint32_t flags = 0;     // SampleFlag bits: sample_partial, sample_after_gap
  std::uint32_t present = 0;   // bit i: encoder i's PDO arrived in this cycle
  std::size_t count = 0;       // number of encoders
  std::array<double, max_encoders> position_m{};
};

// Assembles SYNC cycles from frames. A cycle opens at a SYNC and is emitted as soon as every
// configured node has sent its PDO. Missing PDOs: when the next SYNC arrives before the cycle is
// complete, the cycle is emitted with sample_partial and the missing channels HOLD their previous
// value (NaN if the node never answered); a cycle in which no node answered emits nothing. A second PDO from a node
// within one cycle means a SYNC was missed: the open cycle is emitted (partial if incomplete) and a new cycle opens at
// that PDO's time, flagged sample_after_gap. PDOs before the first SYNC and from unconfigured nodes are ignored.
// A SYNC producer (sync_producer, SYNCs given by sync_sent) misses no SYNC. Where its SYNC is not read
// back from the socket with the PDOs (no echo, below), a second PDO from a node within one cycle means
// the first was a late answer to the SYNC before, and the newer value replaces it (late_pdos). Replacing needs the
// cycle still open: once a cycle was incomplete at its SYNC (the nodes are behind), cycles are emitted
// at the next SYNC instead of as soon as they are complete, until one is complete in time again. And
// a PDO on the bus before our SYNC can still be read after it: an incomplete (or empty) cycle stays
// open past our SYNC until a PDO stamped after it (or the next SYNC) shows nothing more of it can come.
// For an empty cycle "after it" means after its write returned (the SYNC reaches the bus within the
// write, and nodes late together answer the SYNC before); for a partial one, the SYNC's time before the
// write (the node missing may answer the new SYNC during the write).
// All of that is a guess from times, wrong when answers come a period late twice running. A bus that
// gives our own SYNC back in its place among the PDOs (SocketCAN with CAN_RAW_RECV_OWN_MSGS, the
// emulators' gateway) says exactly: fed as a SYNC frame, the echo closes the cycle before it and opens
// our SYNC's at the echo's time, and PDOs go to the cycle open when they are read, as a listener's do;
// an echo two periods (sync_period_ns) or more after the one before flags its cycle sample_after_gap.
// The first echo switches to that for the connection.
class DbbDecoder {
 public:
  struct Result {
    bool cycle_ready = false;  // `cycle` holds an emitted cycle
    FrameInfo info;
  };

  explicit DbbDecoder(std::vector<EncoderScale> encoders, bool sync_producer = false, std::int64_t sync_period_ns = 0);

  // Feeds one frame seen at t_ns. At most one cycle is emitted per frame.
  Result feed(const can_frame& frame, std::int64_t t_ns, DbbCycle& cycle);
  // The SYNC this side (a sync_producer) put on the bus: its time t_ns taken just before the write,
  // written_ns when the write returned. Returns whether a cycle was emitted into `cycle`.
  bool sync_sent(std::int64_t t_ns, std::int64_t written_ns, DbbCycle& cycle);
  // Emits the open cycle if it has data that was not emitted yet (partial); call before resync()
  // when a connection ends so nothing received is lost.
  bool flush(DbbCycle& cycle);
  // The next cycle that opens carries sample_after_gap (after a silence); the open cycle stays, so
  // late PDOs still complete it.
  void mark_gap() noexcept { gap_ = true; }
  // Forget the open cycle (after a reconnect); the next emitted cycle carries sample_after_gap.
  // Unwrapping continues (the encoders kept counting) unless reset_counts is set.
  void resync(bool reset_counts = false);

  // A cycle is open and still waits for PDOs (it was not emitted yet).
  [[nodiscard]] bool cycle_pending() const noexcept { return (open_ && !emitted_) || held_open_; }
  [[nodiscard]] const std::vector<EncoderScale>& encoders() const noexcept { return encoders_; }
  [[nodiscard]] std::uint64_t missed_pdos() const noexcept { return missed_pdos_; }
  [[nodiscard]] std::uint64_t missed_syncs() const noexcept { return missed_syncs_; }
  [[nodiscard]] std::uint64_t empty_cycles() const noexcept { return empty_cycles_; }
  [[nodiscard]] std::uint64_t late_pdos() const noexcept { return late_pdos_; }

 private:
  int index_of(std::uint8_t node) const noexcept;
  void open_cycle(std::int64_t t_ns, std::uint32_t flags);
  void close_cycle(DbbCycle& out);
  bool emit_held(DbbCycle& out);  // false when nobody answered the held SYNC (no sample)
  void store(std::size_t i, std::uint32_t count, DbbCycle& into);
  void feed_position_as_producer(std::size_t i, std::uint32_t count, std::int64_t t_ns, Result& r, DbbCycle& cycle);
  std::int64_t unwrap(std::size_t i, std::uint32_t count) noexcept;
  bool sync_echoed(std::int64_t t_ns, DbbCycle& cycle);  // our SYNC, back from the bus
  bool end_open_cycle(DbbCycle& cycle);                  // at a SYNC: the open cycle emitted (true), or counted empty

  std::vector<EncoderScale> encoders_;
  std::uint32_t all_mask_ = 0;
  bool producer_ = false;
  bool open_ = false;
  bool emitted_ = false;  // the open cycle was already emitted (complete)
  bool gap_ = false;      // next cycle carries sample_after_gap
  DbbCycle cur_;
  bool held_open_ = false;  // `held_` is the incomplete cycle before our own SYNC, not yet emitted
  bool behind_ = false;     // producer: a cycle was incomplete at its SYNC; emit at the next SYNC
  DbbCycle held_;
  std::int64_t held_until_ns_ = 0;  // a PDO stamped before it may still be the held cycle's (sync_sent)
  std::int64_t echo_hole_ns_ = 0;   // producer: echoes this far apart or more follow a hole (0: never said)
  bool echo_ = false;               // producer: the bus gives our SYNCs back in place (feed), cycles follow them
  std::int64_t last_echo_ns_ = 0;
  std::array<double, max_encoders> last_m_{};
  std::array<bool, max_encoders> have_count_{};
  std::array<std::uint32_t, max_encoders> prev_count_{};
  std::array<std::int64_t, max_encoders> unwrapped_{};
  std::uint64_t missed_pdos_ = 0;
  std::uint64_t missed_syncs_ = 0;
  std::uint64_t empty_cycles_ = 0;
  std::uint64_t late_pdos_ = 0;
};

}  // namespace guideway::drivers::dbb
