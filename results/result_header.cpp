#include "results/result_header.hpp"

namespace guideway::results {

namespace {

std::string text(const nlohmann::json& m, const char* key) {
  const auto it = m.find(key);
  return it != m.end() && it->is_string() ? it->get<std::string>() : std::string();
}

}  // namespace

nlohmann::json with_header(nlohmann::json body, const ResultHeader& h) {
  body["session"] = h.session;
  body["kind"] = h.kind;
  body["device"] = h.device;
  if (h.samples) body["samples"] = *h.samples;
  if (!h.recording.empty()) body["recording"] = h.recording;
  if (!h.recording_error.empty()) body["recording_error"] = h.recording_error;
  if (!h.derived.empty()) body["derived"] = h.derived;
  if (!h.replayed_from.empty()) body["replayed_from"] = h.replayed_from;
  return body;
}

ResultHeader read_header(const nlohmann::json& m) {
  ResultHeader h;
  if (!m.is_object()) return h;
  h.session = text(m, "session");
  h.kind = text(m, "kind");
  h.device = text(m, "device");
  if (const auto it = m.find("samples"); it != m.end() && it->is_number_unsigned())
    h.samples = it->get<std::uint64_t>();
  h.recording = text(m, "recording");
  h.recording_error = text(m, "recording_error");
  if (const auto it = m.find("derived"); it != m.end() && it->is_array()) {
    for (const auto& f : *it)
      if (f.is_string()) h.derived.push_back(f.get<std::string>());
  }
  h.replayed_from = text(m, "replayed_from");
  return h;
}

}  // namespace guideway::results
