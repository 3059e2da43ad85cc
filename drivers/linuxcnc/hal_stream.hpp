#pragma once
// The LinuxCNC bridge's stream (docs/linuxcnc.md, "The bridge's stream"): what guideway-linuxcnc-bridge
// serves every client on its Unix socket, one text line each:
//
//   # guideway-linuxcnc-bridge 1            the first line: the stream's format and version
//   # period_ns = 1000000                   LinuxCNC's servo period
//   # columns = x_motor_mm,y_motor_mm,...   the name of each value of a period, in order
//   # end                                   the header's last line
//   1234 12.000001 -3.5 ... 1               one servo period: the sampler's sample number, then the values,
//                                           as `halsampler -t` prints them (floats %f, bits 0/1, s32)
//   ! lost 17 halsampler overrun            periods that will never come, and why
//
// The sample number (LinuxCNC's sampler.N.sample-num, an s32) counts servo periods; a jump that no `! lost`
// line announced is counted as lost too, so no period goes missing silently. HalStreamReader takes the bytes
// as they come and gives the periods. halsampler's own lines (`SEQ v...` and `overrun`) are parsed here too,
// for the bridge. Pure, no I/O; thread safe (one reader per thread).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace guideway::drivers::linuxcnc {

inline constexpr std::string_view hal_stream_magic = "# guideway-linuxcnc-bridge 1";

// The columns of the HAL configuration Guideway ships (linuxcnc/guideway-bridge.hal): per joint of
// trivial kinematics X Y Z the command to the drive (motor-pos-cmd: after LinuxCNC's backlash and screw
// compensation), the joint's command (pos-cmd: before them, the external offsets included) and the
// homing offset (motor-offset), then the program's line, LinuxCNC's motion type, the session pin and
// the external offset applied to each axis (axis.L.eoffset).
inline constexpr std::string_view default_columns =
    "x_motor_mm,y_motor_mm,z_motor_mm,x_cmd_mm,y_cmd_mm,z_cmd_mm,x_motor_offset_mm,y_motor_offset_mm,"
    "z_motor_offset_mm,program_line,motion_type,session,x_eoffset_mm,y_eoffset_mm,z_eoffset_mm";
// The sampler's cfg string of those columns (F float, S s32, B bit).
inline constexpr std::string_view default_sampler_cfg = "fffffffffssbfff";

struct HalStreamHeader {
  std::int64_t period_ns = 0;
  std::vector<std::string> columns;
  // Index of a column by name, or -1.
  [[nodiscard]] int column(std::string_view name) const;
};

// The header's lines for these columns (each ending in '\n').
std::string format_hal_stream_header(const HalStreamHeader& header);

// "a,b,c" -> {"a","b","c"}; throws std::invalid_argument for an empty name or one twice.
std::vector<std::string> parse_column_list(std::string_view text);

// One line of `halsampler -t`: the sample number and `count` numbers. False (and `error` says why) when the
// line is not that: a value that is not a number, too few or too many values.
bool parse_period_line(std::string_view line, std::size_t count, std::int64_t& seq, std::span<double> values,
                       std::string& error);

// Periods from a sample number to the next: 1 for consecutive numbers; the s32 counter wraps around.
std::int64_t seq_step(std::int64_t from, std::int64_t to);

struct HalStreamCounters {
  std::uint64_t periods = 0;      // periods received
  std::uint64_t lost = 0;         // periods announced lost (`! lost`) or missing between sample numbers
  std::uint64_t lost_unannounced = 0;  // of those, the ones no `! lost` line announced (a sample-number jump)
  std::uint64_t bad_lines = 0;    // lines that were none of the above (counted, skipped)
};

// Reads a bridge stream from its bytes. Calls on_period for every period, in order, with the values in
// the header's column order. A line longer than 64 KiB or a stream without the magic first line is an
// error (error() says which; the reader then ignores the rest).
class HalStreamReader {
 public:
  using PeriodFn = std::function<void(std::int64_t seq, std::span<const double> values)>;
  using LostFn = std::function<void(std::uint64_t periods, std::string_view reason)>;
  explicit HalStreamReader(PeriodFn on_period, LostFn on_lost = {});

  void feed(std::string_view bytes);
  [[nodiscard]] bool header_complete() const noexcept { return header_done_; }
  [[nodiscard]] const HalStreamHeader& header() const noexcept { return header_; }
  [[nodiscard]] const HalStreamCounters& counters() const noexcept { return counters_; }
  [[nodiscard]] const std::string& error() const noexcept { return error_; }
  [[nodiscard]] const std::string& last_bad_line() const noexcept { return last_bad_; }

 private:
  void line(std::string_view text);
  void header_line(std::string_view text);
  void lost(std::uint64_t periods, std::string_view reason, bool announced);

  PeriodFn on_period_;
  LostFn on_lost_;
  std::string partial_;
  HalStreamHeader header_;
  bool magic_seen_ = false;
  bool header_done_ = false;
  bool have_seq_ = false;
  std::int64_t last_seq_ = 0;
  std::uint64_t announced_ = 0;  // periods a `! lost` line announced that the sample numbers have not yet skipped
  std::vector<double> values_;
  HalStreamCounters counters_;
  std::string error_;
  std::string last_bad_;
};

}  // namespace guideway::drivers::linuxcnc
