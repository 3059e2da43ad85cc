// Replay of a raw recording (replay.hpp): its samples fed through the session kind the daemon ran live.
#include "sessions/replay.hpp"

#include <algorithm>
#include <span>
#include <stdexcept>

#include "core/utc_time.hpp"
#include "formats/raw_recording.hpp"

namespace guideway::sessions {

namespace {

nlohmann::json json_meta(const formats::RawRecording& r, const std::string& key, nlohmann::json fallback) {
  const auto it = r.metadata.find(key);
  if (it == r.metadata.end()) return fallback;
  auto j = nlohmann::json::parse(it->second, nullptr, false);
  if (j.is_discarded()) throw std::runtime_error(r.path + ": header \"" + key + "\" is not valid JSON");
  return j;
}

}  // namespace

ReplayResult replay_recording(const std::string& path, const SessionRegistry& registry) {
  const formats::RawRecording recording = formats::read_raw_recording(path);
  ReplayResult result;
  result.complete = recording.complete;
  result.end_marker = recording.end_marker;
  result.samples_lost = recording.samples_lost;
  result.dropped_partial_line = recording.dropped_partial_line;

  std::vector<drivers::ChannelInfo> channels;
  for (const auto& c : recording.channels) channels.push_back({c.name, c.unit});
  const RecordedDevice device(recording.device, recording.driver, channels);
  const std::string kind_name = recording.required("kind");
  const SessionKind* kind = registry.find(kind_name);
  if (kind == nullptr) throw std::runtime_error(path + ": session kind \"" + kind_name + "\" is unknown to this build");
  nlohmann::json options = json_meta(recording, "options", nlohmann::json::object());
  if (kind->recorded_options) options = kind->recorded_options(std::move(options), recording.metadata);
  SessionRequest request{kind_name, device.name(), std::move(options), recording.instrument};
  std::unique_ptr<Session> session;
  try {
    session = kind->create(request, device);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(path + ": the recorded options are refused: " + e.what());
  }
  // Sessions see the raw samples (a recording made before they did has a `processing` header: its live
  // session assembled the denoised stream, so its published result may differ from this one).
  if (recording.metadata.count("processing") > 0)
    result.note = "recorded when sessions assembled the processed stream; replayed from the raw samples";

  // The samples in the pieces the pipeline feeds a live session in.
  const std::span<const Sample> samples(recording.samples);
  for (std::size_t offset = 0; offset < samples.size(); offset += max_feed_batch) {
    const auto batch = samples.subspan(offset, std::min(max_feed_batch, samples.size() - offset));
    session->on_samples(batch);
    result.samples += batch.size();
  }

  try {
    result.parameters = session->identify();
  } catch (const std::exception& e) {
    result.failure = e.what();
    return result;
  }
  results::ResultHeader& header = result.header;
  header.session = recording.required("session");
  header.kind = kind_name;
  header.device = device.name();
  header.samples = result.samples;
  header.replayed_from = path;
  header.instrument = recording.instrument;
  // Judged on the day the session started, as the live session judged it.
  if (const auto started =
          parse_utc_iso(recording.metadata.count("started_utc") ? recording.metadata.at("started_utc") : ""))
    header.instrument_checked_on = utc_date(*started);
  try {
    result.explanation = session->explain();
  } catch (const std::exception& e) {
    result.explain_failure = e.what();
  }
  return result;
}

}  // namespace guideway::sessions
