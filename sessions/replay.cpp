#include "sessions/replay.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/csv_table.hpp"

namespace guideway::sessions {

namespace {

// The device of a recording: its name, driver and channels, never started.
class RecordedDevice : public drivers::Driver {
 public:
  RecordedDevice(std::string name, std::string driver, std::vector<drivers::ChannelInfo> channels)
      : Driver(std::move(name), std::move(driver), std::move(channels), 2) {}

 protected:
  void run(std::stop_token) override {}
};

std::string meta(const CsvTable& t, const std::string& key) {
  const auto it = t.metadata.find(key);
  if (it == t.metadata.end() || it->second.empty()) {
    throw std::runtime_error(t.source + ": not a complete raw recording header (no \"" + key + "\")");
  }
  return it->second;
}

nlohmann::json json_meta(const CsvTable& t, const std::string& key, nlohmann::json fallback) {
  const auto it = t.metadata.find(key);
  if (it == t.metadata.end()) return fallback;
  auto j = nlohmann::json::parse(it->second, nullptr, false);
  if (j.is_discarded()) throw std::runtime_error(t.source + ": header \"" + key + "\" is not valid JSON");
  return j;
}

// The recorder writes a non-finite reading as to_chars does ("nan", "inf", "-inf").
double channel_value(const CsvTable& t, const CsvTable::Row& row, std::size_t col) {
  const std::string& cell = row.cells[col];
  if (cell == "nan" || cell == "-nan") return std::numeric_limits<double>::quiet_NaN();
  if (cell == "inf") return std::numeric_limits<double>::infinity();
  if (cell == "-inf") return -std::numeric_limits<double>::infinity();
  return t.number(row, col);
}

}  // namespace

ReplayResult replay_recording(const std::string& path, const SessionRegistry& registry) {
  ReplayResult result;
  std::string text = read_text_file(path);
  // A daemon killed in the middle of a write() can leave a last line without its newline: not data.
  if (!text.empty() && text.back() != '\n') {
    text.erase(text.find_last_of('\n') == std::string::npos ? 0 : text.find_last_of('\n') + 1);
    result.dropped_partial_line = 1;
  }
  const CsvTable t = parse_csv_table(text, path);
  if (meta(t, "format") != "guideway/raw/1") {
    throw std::runtime_error(path + ": format \"" + meta(t, "format") + "\" is not a raw recording (guideway/raw/1)");
  }
  // `end = aborted`: the daemon stopped mid-session (or identification failed): not a whole session.
  const auto end = t.metadata.find("end");
  result.complete = end != t.metadata.end() && end->second == "complete" && !path.ends_with(".part");
  if (end != t.metadata.end()) result.end_marker = end->second;
  // Rows the recorder dropped (a disk that refused them for long): the live session saw them, the
  // replay cannot, so its result is not the live one.
  if (const auto lost = t.metadata.find("samples_lost"); lost != t.metadata.end()) {
    try {
      result.samples_lost = std::stoull(lost->second);
    } catch (const std::exception&) {
      throw std::runtime_error(path + ": samples_lost: not a count: '" + lost->second + "'");
    }
    if (result.samples_lost > 0) result.complete = false;
  }

  // Columns t_mono_ns, seq, flags, then <channel>_<unit>.
  const std::size_t t_col = t.column("t_mono_ns");
  const std::size_t seq_col = t.column("seq");
  const std::size_t flags_col = t.column("flags");
  std::vector<drivers::ChannelInfo> channels;
  std::vector<std::size_t> channel_cols;
  for (std::size_t c = 0; c < t.columns.size(); ++c) {
    if (c == t_col || c == seq_col || c == flags_col) continue;
    const auto& name = t.columns[c];
    const auto underscore = name.rfind('_');
    if (underscore == std::string::npos || underscore == 0) {
      throw std::runtime_error(path + ": column \"" + name + "\" is not <channel>_<unit>");
    }
    channels.push_back({name.substr(0, underscore), name.substr(underscore + 1)});
    channel_cols.push_back(c);
  }
  if (channels.size() > max_sample_values) throw std::runtime_error(path + ": more channels than a sample holds");

  const RecordedDevice device(meta(t, "device"), meta(t, "driver"), channels);
  const std::string kind_name = meta(t, "kind");
  const SessionKind* kind = registry.find(kind_name);
  if (kind == nullptr) throw std::runtime_error(path + ": session kind \"" + kind_name + "\" is unknown to this build");
  SessionRequest request{kind_name, device.name(), json_meta(t, "options", nlohmann::json::object())};
  std::unique_ptr<Session> session;
  try {
    session = kind->create(request, device);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(path + ": the recorded options are refused: " + e.what());
  }
  // Sessions see the raw samples (a recording made before they did has a `processing` header: its live
  // session assembled the denoised stream, so its published result may differ from this one).
  if (t.metadata.count("processing") > 0)
    result.note = "recorded when sessions assembled the processed stream; replayed from the raw samples";

  // The samples in the pieces the pipeline feeds a live session in.
  std::vector<Sample> batch;
  batch.reserve(max_feed_batch);
  const auto feed = [&] {
    session->on_samples(batch);
    result.samples += batch.size();
    batch.clear();
  };
  for (const auto& row : t.rows) {
    Sample s;
    s.t_mono_ns = static_cast<std::int64_t>(t.number(row, t_col));
    s.seq = static_cast<std::uint64_t>(t.number(row, seq_col));
    s.flags = static_cast<std::uint32_t>(t.number(row, flags_col));
    for (std::size_t c = 0; c < channel_cols.size(); ++c) {
      if (row.cells[channel_cols[c]].empty()) break;  // the channels a sample lacks are the last ones
      s.value[c] = channel_value(t, row, channel_cols[c]);
      s.value_count = static_cast<std::uint32_t>(c + 1);
    }
    batch.push_back(s);
    if (batch.size() == max_feed_batch) feed();
  }
  if (!batch.empty()) feed();

  try {
    result.params = session->identify();
  } catch (const std::exception& e) {
    result.failure = e.what();
    return result;
  }
  result.params["class"] = "PARAMS";
  result.params["session"] = meta(t, "session");
  result.params["kind"] = kind_name;
  result.params["device"] = device.name();
  result.params["samples"] = result.samples;
  result.params["replayed_from"] = path;
  try {
    if (auto report = session->explain()) {
      result.explain = std::move(*report);
      result.explain["class"] = "EXPLAIN";
      result.explain["session"] = result.params["session"];
      result.explain["kind"] = kind_name;
      result.explain["device"] = device.name();
      result.explain["replayed_from"] = path;
    }
  } catch (const std::exception& e) {
    result.explain_failure = e.what();
  }
  return result;
}

}  // namespace guideway::sessions
