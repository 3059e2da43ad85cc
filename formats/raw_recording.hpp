#pragma once
// Raw recordings (guideway/raw/1, docs/formats.md "Raw recordings"): one device's samples of one
// session, as they arrived. The one writer and the one reader of the format:
//   - writing is streamed (the recorder appends rows while the session runs): the header, one row per
//     sample, the trailer at the end, each as text the caller writes;
//   - reading gives the header and trailer keys, the channels and every sample, and says whether the
//     recording is whole (replay);
//   - listing finds the recordings in a directory by their first line (the daemon's `recordings`).
// Pure apart from reading files; thread safe. Errors are std::runtime_error "file[:line]: message".

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/instrument.hpp"
#include "core/sample.hpp"

namespace guideway::formats {

inline constexpr std::string_view raw_format_id = "guideway/raw/1";

// One channel column, named `<name>_<unit>` (SI unit).
struct RawChannel {
  std::string name;
  std::string unit;
};

// The header of a recording: the device, when it started, the session's own keys (`session`, `kind`,
// `options`, geometry...) and the channels.
struct RawRecordingHeader {
  std::string device;
  std::string driver;
  std::string started_utc;  // wall clock, ISO 8601 with milliseconds
  std::int64_t started_mono_ns = 0;
  std::map<std::string, std::string> metadata;
  std::vector<RawChannel> channels;
};

// The instrument that made the recording, as header keys (`instrument_serial`,
// `instrument_calibration_certificate`, `instrument_calibrated_on`, `instrument_calibration_due`,
// `instrument_calibrated_length_mm`, `instrument_calibrated_length_u_um`): only the parts stated. The
// recorder writes them with the session's keys (RawRecordingHeader::metadata).
[[nodiscard]] std::map<std::string, std::string> instrument_metadata(const Instrument& instrument);
// The instrument of such keys (the inverse: other keys are ignored). Throws std::runtime_error naming `where`
// and the key of an instrument_* value that is not a date or number.
[[nodiscard]] Instrument instrument_from_metadata(const std::map<std::string, std::string>& metadata,
                                                  const std::string& where);

// The trailer, appended when the session ends.
struct RawRecordingTrailer {
  bool complete = false;  // `end = complete`, else `end = aborted`
  std::string ended_utc;
  std::uint64_t samples = 0;
  std::uint64_t samples_lost = 0;
  std::map<std::string, std::string> metadata;  // e.g. identification_error
};

// --- writing ---
// DIR/NAME.csv.part while it is written, DIR/NAME.csv once it is whole.
[[nodiscard]] std::string raw_recording_part_path(const std::string& dir, const std::string& name);
[[nodiscard]] std::string raw_recording_path(const std::string& dir, const std::string& name);
// The metadata lines and the column row. A newline in a key or value is written as a blank (one line each).
[[nodiscard]] std::string format_raw_header(const RawRecordingHeader& header);
// Appends one sample's row; `channel_count` cells after t_mono_ns,seq,flags, empty for the channels the
// sample lacks.
void append_raw_row(std::string& out, const Sample& sample, std::size_t channel_count);
[[nodiscard]] std::string format_raw_trailer(const RawRecordingTrailer& trailer);

// --- reading ---
struct RawRecording {
  std::string path;
  std::map<std::string, std::string> metadata;  // every header and trailer key, as written
  std::string device;
  std::string driver;
  std::vector<RawChannel> channels;
  std::vector<Sample> samples;
  bool complete = true;         // false: a .part, no `# end =` trailer, `end = aborted`, or samples lost
  std::string end_marker;       // the trailer's `end` (complete, aborted), "" when there is none
  std::uint64_t samples_lost = 0;        // the trailer's `samples_lost`: rows the recorder could not write
  std::size_t dropped_partial_line = 0;  // 1 when a last line without its newline was ignored (a kill)
  Instrument instrument;                 // from the instrument_* keys; empty in a recording without them

  // A key that must be in the header (e.g. `kind`, `session`); throws
  // "PATH: not a complete raw recording header (no "KEY")" when it is absent or empty.
  [[nodiscard]] const std::string& required(const std::string& key) const;
};

// Reads a whole recording, or what an interrupted session left (NAME.csv.part, no trailer, a last line
// cut short). Throws std::runtime_error naming the file (and the line of a bad cell) for a file that is
// not a raw recording, or naming the key of an instrument_* value that is not a date or number.
[[nodiscard]] RawRecording read_raw_recording(const std::string& path);

// True when the file's first line is `# format = guideway/raw/1`.
[[nodiscard]] bool is_raw_recording(const std::string& path);
// Whether `text` (a file's beginning) is a raw recording's: its first line is the format line.
[[nodiscard]] bool is_raw_recording_text(std::string_view text);

struct RawRecordingEntry {
  std::string path;
  std::uintmax_t bytes = 0;
  bool complete = false;  // NAME.csv; a NAME.csv.part is still written or was interrupted
};
// The files a session derived from the raw recording `path` (NAME.csv or NAME.csv.part): NAME.*.csv beside
// it (the DBB run files NAME.runK.csv, a traverse, ...; not the recording), sorted by path.
[[nodiscard]] std::vector<std::string> derived_files(const std::string& path);
// The refusal of a raw recording given where `wanted` ("DBB run files") is expected: a raw recording is what
// a session measured, not a result; `instead` (files derived from it) are named, or how to make them.
[[nodiscard]] std::string raw_recording_refusal(const std::string& path, const std::vector<std::string>& instead,
                                                std::string_view wanted);

// The raw recordings in `dir` (NAME.csv and NAME.csv.part files that are raw recordings, not the
// derived CSV files beside them), sorted by path; none when the directory cannot be read.
[[nodiscard]] std::vector<RawRecordingEntry> list_raw_recordings(const std::string& dir);

}  // namespace guideway::formats
