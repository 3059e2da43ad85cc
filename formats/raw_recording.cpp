// Raw recordings (raw_recording.hpp, guideway/raw/1): the one writer and the one reader of a device's samples as they
// arrived.
#include "formats/raw_recording.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>

#include "core/csv_table.hpp"
#include "core/number_format.hpp"

namespace guideway::formats {

namespace {

constexpr std::string_view part_suffix = ".part";

// Metadata values are one line each: a newline would end the header.
std::string one_line(std::string s) {
  for (char& c : s) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return s;
}

std::string format_line() { return "# format = " + std::string(raw_format_id); }

void append_metadata(std::string& out, const std::map<std::string, std::string>& metadata) {
  for (const auto& [k, v] : metadata) out += "# " + one_line(k) + " = " + one_line(v) + "\n";
}

std::string meta(const CsvTable& t, const std::string& key) {
  const auto it = t.metadata.find(key);
  if (it == t.metadata.end() || it->second.empty()) {
    throw std::runtime_error(t.source + ": not a complete raw recording header (no \"" + key + "\")");
  }
  return it->second;
}

// The recorder writes a non-finite reading as to_chars does ("nan", "inf", "-inf").
double channel_value(const CsvTable& t, const CsvTable::Row& row, std::size_t col) {
  const std::string_view cell = t.cell(row, col);
  if (cell == "nan" || cell == "-nan") return std::numeric_limits<double>::quiet_NaN();
  if (cell == "inf") return std::numeric_limits<double>::infinity();
  if (cell == "-inf") return -std::numeric_limits<double>::infinity();
  return t.number(row, col);
}

constexpr const char* key_serial = "instrument_serial";
constexpr const char* key_certificate = "instrument_calibration_certificate";
constexpr const char* key_calibrated_on = "instrument_calibrated_on";
constexpr const char* key_due = "instrument_calibration_due";
constexpr const char* key_length = "instrument_calibrated_length_mm";
constexpr const char* key_length_u = "instrument_calibrated_length_u_um";

Instrument read_instrument(const std::map<std::string, std::string>& m, const std::string& path) {
  Instrument in;
  const auto text = [&](const char* key) {
    const auto it = m.find(key);
    return it == m.end() ? std::string() : it->second;
  };
  in.serial = text(key_serial);
  in.calibration_certificate = text(key_certificate);
  const auto date = [&](const char* key) -> std::optional<CalendarDate> {
    const std::string v = text(key);
    if (v.empty()) return std::nullopt;
    const auto d = parse_iso_date(v);
    if (!d) throw std::runtime_error(path + ": " + key + ": not a date YYYY-MM-DD: '" + v + "'");
    return d;
  };
  in.calibrated_on = date(key_calibrated_on);
  in.calibration_due = date(key_due);
  const auto number = [&](const char* key) -> std::optional<double> {
    const std::string v = text(key);
    if (v.empty()) return std::nullopt;
    double x = 0;
    const auto r = std::from_chars(v.data(), v.data() + v.size(), x);
    if (r.ec != std::errc() || r.ptr != v.data() + v.size() || !std::isfinite(x))
      throw std::runtime_error(path + ": " + key + ": not a number: '" + v + "'");
    return x;
  };
  in.calibrated_length_mm = number(key_length);
  in.calibrated_length_u_um = number(key_length_u);
  return in;
}

}  // namespace

Instrument instrument_from_metadata(const std::map<std::string, std::string>& metadata, const std::string& where) {
  return read_instrument(metadata, where);
}

std::map<std::string, std::string> instrument_metadata(const Instrument& in) {
  std::map<std::string, std::string> m;
  if (!in.serial.empty()) m[key_serial] = in.serial;
  if (!in.calibration_certificate.empty()) m[key_certificate] = in.calibration_certificate;
  if (in.calibrated_on) m[key_calibrated_on] = to_iso(*in.calibrated_on);
  if (in.calibration_due) m[key_due] = to_iso(*in.calibration_due);
  if (in.calibrated_length_mm) m[key_length] = shortest(*in.calibrated_length_mm);
  if (in.calibrated_length_u_um) m[key_length_u] = shortest(*in.calibrated_length_u_um);
  return m;
}

std::string raw_recording_part_path(const std::string& dir, const std::string& name) {
  return raw_recording_path(dir, name) + std::string(part_suffix);
}

std::string raw_recording_path(const std::string& dir, const std::string& name) { return dir + "/" + name + ".csv"; }

std::string format_raw_header(const RawRecordingHeader& header) {
  std::string out = format_line() + "\n";
  out += "# device = " + one_line(header.device) + "\n";
  out += "# driver = " + one_line(header.driver) + "\n";
  out += "# started_utc = " + header.started_utc + "\n";
  out += "# started_mono_ns = " + std::to_string(header.started_mono_ns) + "\n";
  append_metadata(out, header.metadata);
  out += "t_mono_ns,seq,flags";
  for (const auto& c : header.channels) out += "," + c.name + "_" + c.unit;
  out += "\n";
  return out;
}

void append_raw_row(std::string& out, const Sample& sample, std::size_t channel_count) {
  out += std::to_string(sample.t_mono_ns);
  out += ',';
  out += std::to_string(sample.seq);
  out += ',';
  out += std::to_string(sample.flags);
  for (std::size_t c = 0; c < channel_count; ++c) {
    out += ',';
    if (c < sample.value_count) append_shortest(out, sample.value[c]);
  }
  out += '\n';
}

std::string format_raw_trailer(const RawRecordingTrailer& trailer) {
  std::string out = "# end = " + std::string(trailer.complete ? "complete" : "aborted") + "\n";
  out += "# ended_utc = " + trailer.ended_utc + "\n";
  out += "# samples = " + std::to_string(trailer.samples) + "\n";
  out += "# samples_lost = " + std::to_string(trailer.samples_lost) + "\n";
  append_metadata(out, trailer.metadata);
  return out;
}

const std::string& RawRecording::required(const std::string& key) const {
  const auto it = metadata.find(key);
  if (it == metadata.end() || it->second.empty()) {
    throw std::runtime_error(path + ": not a complete raw recording header (no \"" + key + "\")");
  }
  return it->second;
}

RawRecording read_raw_recording(const std::string& path) {
  RawRecording r;
  r.path = path;
  std::string text = read_text_file(path);
  // A daemon killed in the middle of a write() can leave a last line without its newline: not data.
  if (!text.empty() && text.back() != '\n') {
    text.erase(text.find_last_of('\n') == std::string::npos ? 0 : text.find_last_of('\n') + 1);
    r.dropped_partial_line = 1;
  }
  const CsvTable t = parse_csv_table(text, path);
  if (meta(t, "format") != raw_format_id) {
    throw std::runtime_error(path + ": format \"" + meta(t, "format") + "\" is not a raw recording (" +
                             std::string(raw_format_id) + ")");
  }
  // `end = aborted`: the daemon stopped mid-session (or identification failed): not a whole session.
  const auto end = t.metadata.find("end");
  r.complete = end != t.metadata.end() && end->second == "complete" && !path.ends_with(part_suffix);
  if (end != t.metadata.end()) r.end_marker = end->second;
  // Rows the recorder dropped (a disk that refused them for long): the live session saw them, a
  // reader cannot.
  if (const auto lost = t.metadata.find("samples_lost"); lost != t.metadata.end()) {
    try {
      r.samples_lost = std::stoull(lost->second);
    } catch (const std::exception&) {
      throw std::runtime_error(path + ": samples_lost: not a count: '" + lost->second + "'");
    }
    if (r.samples_lost > 0) r.complete = false;
  }

  // Columns t_mono_ns, seq, flags, then <channel>_<unit>.
  const std::size_t t_col = t.column("t_mono_ns");
  const std::size_t seq_col = t.column("seq");
  const std::size_t flags_col = t.column("flags");
  std::vector<std::size_t> channel_cols;
  for (std::size_t c = 0; c < t.columns.size(); ++c) {
    if (c == t_col || c == seq_col || c == flags_col) continue;
    const auto& name = t.columns[c];
    const auto underscore = name.rfind('_');
    if (underscore == std::string::npos || underscore == 0) {
      throw std::runtime_error(path + ": column \"" + name + "\" is not <channel>_<unit>");
    }
    r.channels.push_back({name.substr(0, underscore), name.substr(underscore + 1)});
    channel_cols.push_back(c);
  }
  if (r.channels.size() > max_sample_values) throw std::runtime_error(path + ": more channels than a sample holds");
  r.device = meta(t, "device");
  r.driver = meta(t, "driver");

  r.samples.reserve(t.rows.size());
  for (const auto& row : t.rows) {
    Sample s;
    // Within the integer types they are read into (a double beyond one has no defined conversion).
    s.t_mono_ns = static_cast<std::int64_t>(t.number_in(row, t_col, 0, 9.2e18, "ns, a monotonic clock's time"));
    s.seq = static_cast<std::uint64_t>(t.number_in(row, seq_col, 0, 1.8e19, "a sequence number"));
    s.flags = static_cast<std::uint32_t>(t.number_in(row, flags_col, 0, 4294967295.0, "32 flag bits"));
    for (std::size_t c = 0; c < channel_cols.size(); ++c) {
      if (t.cell(row, channel_cols[c]).empty()) break;  // the channels a sample lacks are the last ones
      s.value[c] = channel_value(t, row, channel_cols[c]);
      s.value_count = static_cast<std::uint32_t>(c + 1);
    }
    r.samples.push_back(s);
  }
  r.metadata = t.metadata;
  r.instrument = read_instrument(r.metadata, path);
  return r;
}

bool is_raw_recording_text(std::string_view text) {
  const std::string line = format_line();
  return text.starts_with(line) && (text.size() == line.size() || text[line.size()] == '\n');
}

bool is_raw_recording(const std::string& path) {
  try {  // the checks of every input: a FIFO or a device is no recording, and is not waited on
    return is_raw_recording_text(read_file_head(path, 64));
  } catch (const CsvError&) {
    return false;
  }
}

std::vector<std::string> derived_files(const std::string& path) {
  const std::filesystem::path p(path);
  std::string stem = p.filename().string();  // NAME of NAME.csv or NAME.csv.part
  if (stem.ends_with(part_suffix)) stem.resize(stem.size() - part_suffix.size());
  if (stem.ends_with(".csv")) stem.resize(stem.size() - 4);
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(
           p.parent_path().empty() ? std::filesystem::path(".") : p.parent_path(), ec)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file(ec) && name != p.filename().string() && name.starts_with(stem + ".") &&
        name.ends_with(".csv"))
      out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string raw_recording_refusal(const std::string& path, const std::vector<std::string>& instead,
                                  std::string_view wanted) {
  std::string msg = path + ": a raw recording (" + std::string(raw_format_id) + ", the samples as they arrived), not " +
                    std::string(wanted) + "; ";
  if (instead.empty())
    return msg +
           "no such file derived from it lies beside it (a session that ended writes NAME.run1.csv, "
           "NAME.traverse.csv, ...; `guideway replay " +
           path + "` identifies it again)";
  msg += "give the files the session derived from it:";
  for (const auto& d : instead) msg += " " + d;
  return msg;
}

std::vector<RawRecordingEntry> list_raw_recordings(const std::string& dir) {
  std::vector<RawRecordingEntry> out;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    const std::string n = e.path().filename().string();
    const bool part = n.ends_with(".csv" + std::string(part_suffix));
    if (!n.ends_with(".csv") && !part) continue;
    if (is_raw_recording(e.path().string())) out.push_back({e.path().string(), e.file_size(ec), !part});
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.path < b.path; });
  return out;
}

}  // namespace guideway::formats
