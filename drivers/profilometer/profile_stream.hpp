#pragma once
// The profilometer stream protocol (docs/protocols.md, "Profilometer stream"): ASCII lines
// "<body>*HH\n" with an XOR checksum, carrying a banner, a header per traverse, points and an end
// record. Formatting, the one-line parser and the ProfileAssembler are pure (no I/O, no clock), so
// the driver, the emulator and the fuzz tests share them.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace guideway::drivers::profilometer {

// Sample flag bits of this driver (above the generic SampleFlag bits).
inline constexpr std::uint32_t sample_profile_start = 1u << 8;  // first point of a traverse
inline constexpr std::uint32_t sample_profile_end = 1u << 9;    // last point of a traverse (END received)

inline constexpr int stream_protocol_version = 1;
inline constexpr std::size_t max_line_bytes = 256;  // longer lines are garbage

// One traverse as announced by its HDR record. Lengths in metres; scales convert stream units to metres.
struct ProfileHeader {
  std::uint64_t id = 0;
  std::uint64_t points = 0;
  double length_m = 0.0;                          // traverse length
  double spacing_m = 0.0;                         // point spacing along x
  double tip_radius_m = 0.0;                      // stylus tip radius (0: not given)
  double z_range_m = 0.0;                         // gauge range (0: not given)
  double speed_m_per_s = 0.0;                     // traverse speed (0: not given)
  std::string stylus;                             // stylus name, no spaces
  std::string x_unit = "mm";                      // "m", "mm" or "um"
  std::string z_unit = "um";                      // "mm", "um" or "nm"
  [[nodiscard]] double x_scale() const noexcept;  // metres per x unit
  [[nodiscard]] double z_scale() const noexcept;  // metres per z unit
};

// --- line codec ---
std::uint8_t line_checksum(std::string_view body) noexcept;  // XOR of the body's bytes
std::string frame_line(std::string_view body);               // body + "*HH\n"
std::string format_banner(std::string_view instrument);      // "GWPROF 1 <instrument>"
std::string format_header(const ProfileHeader& h);           // "HDR id=.. points=.. ..."
// "P <index> <x> <z>" in the header's units; z is "OVR" when over_range.
std::string format_point(std::uint64_t index, double x_m, double z_m, const ProfileHeader& h, bool over_range = false);
std::string format_end(std::uint64_t id, std::uint64_t points);  // "END <id> <points>"
std::string format_idle();                                       // "IDLE"

enum class LineKind { banner, header, point, end, idle };
struct ParsedLine {
  LineKind kind = LineKind::idle;
  int version = 0;          // banner
  std::string instrument;   // banner
  ProfileHeader header;     // header
  std::uint64_t id = 0;     // end
  std::uint64_t count = 0;  // end: points sent
  std::uint64_t index = 0;  // point
  double x = 0.0, z = 0.0;  // point, in the header's units
  bool over_range = false;  // point
};
// Parses one framed line without its '\n' (a trailing '\r' is accepted). Never throws; on failure
// returns nullopt and, if error is given, why.
std::optional<ParsedLine> parse_line(std::string_view line, std::string* error = nullptr);

// --- assembly ---
struct StreamEvent {
  enum class Type { point, bad_line, banner, header, end };
  Type type = Type::point;
  std::uint64_t profile_id = 0;
  std::uint64_t index = 0;
  double x_m = 0.0, z_m = 0.0;  // point (z NaN when over range)
  std::uint32_t flags = 0;      // point: SampleFlag bits + sample_profile_start/end
  std::int64_t t_ns = 0;        // point: the time passed to feed() with the bytes that carried it
  std::string message;          // bad_line: why
  std::uint64_t points_lost = 0;  // end: points the END counts that did not arrive whole
};

// Splits bytes into lines, parses them and assembles traverses. A point is held back until the next
// line arrives, so the last point of a traverse can carry sample_profile_end; finish() releases it.
// Not thread safe.
class ProfileAssembler {
 public:
  void feed(std::string_view bytes, std::int64_t t_ns, std::vector<StreamEvent>& out);
  // The connection ended: releases the held point (not marked as an end), drops any partial line, and
  // flags the next point after_gap.
  void finish(std::vector<StreamEvent>& out);
  [[nodiscard]] const std::optional<ProfileHeader>& header() const noexcept { return header_; }

 private:
  void on_line(std::string_view line, std::int64_t t_ns, std::vector<StreamEvent>& out);
  void release(std::vector<StreamEvent>& out);

  std::string line_;
  bool discarding_ = false;  // inside an overlong line: skip to the next '\n'
  std::optional<ProfileHeader> header_;
  std::optional<StreamEvent> held_;
  std::uint64_t expected_index_ = 0;
  std::uint64_t received_ = 0;  // points of this traverse taken
  bool next_start_ = false;
  bool gap_ = false;
};

}  // namespace guideway::drivers::profilometer
