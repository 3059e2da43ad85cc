// The header every PARAMS and EXPLAIN carries (result_header.hpp): session, kind, device and where its data is, written
// and read.
#include "results/result_header.hpp"

namespace guideway::results {

namespace {

std::string text(const nlohmann::json& m, const char* key) {
  const auto it = m.find(key);
  return it != m.end() && it->is_string() ? it->get<std::string>() : std::string();
}

std::optional<CalendarDate> date(const nlohmann::json& m, const char* key) { return parse_iso_date(text(m, key)); }

std::optional<double> number(const nlohmann::json& m, const char* key) {
  const auto it = m.find(key);
  if (it == m.end() || !it->is_number()) return std::nullopt;
  return it->get<double>();
}

Instrument read_instrument(const nlohmann::json& j) {
  Instrument in;
  if (!j.is_object()) return in;
  in.serial = text(j, "serial");
  in.calibration_certificate = text(j, "calibration_certificate");
  in.calibrated_on = date(j, "calibrated_on");
  in.calibration_due = date(j, "calibration_due");
  in.calibrated_length_mm = number(j, "calibrated_length_mm");
  in.calibrated_length_u_um = number(j, "calibrated_length_u_um");
  return in;
}

}  // namespace

nlohmann::json instrument_json(const std::string& device, const Instrument& in, const CalendarDate& checked_on) {
  if (in.empty()) return nullptr;
  nlohmann::json j = nlohmann::json::object();
  if (!in.serial.empty()) j["serial"] = in.serial;
  if (!in.calibration_certificate.empty()) j["calibration_certificate"] = in.calibration_certificate;
  if (in.calibrated_on) j["calibrated_on"] = to_iso(*in.calibrated_on);
  if (in.calibration_due) j["calibration_due"] = to_iso(*in.calibration_due);
  if (in.calibrated_length_mm) j["calibrated_length_mm"] = *in.calibrated_length_mm;
  if (in.calibrated_length_u_um) j["calibrated_length_u_um"] = *in.calibrated_length_u_um;
  j["checked_on"] = to_iso(checked_on);
  if (in.calibration_due) {
    j["calibration_expired"] = calibration_expired(in, checked_on);
    if (const std::string w = calibration_warning(device, in, checked_on); !w.empty()) j["warning"] = w;
  }
  return j;
}

nlohmann::json with_header(nlohmann::json body, const ResultHeader& h) {
  body["session"] = h.session;
  body["kind"] = h.kind;
  body["device"] = h.device;
  if (h.samples) body["samples"] = *h.samples;
  if (!h.recording.empty()) body["recording"] = h.recording;
  if (!h.recording_error.empty()) body["recording_error"] = h.recording_error;
  if (!h.derived.empty()) body["derived"] = h.derived;
  if (!h.replayed_from.empty()) body["replayed_from"] = h.replayed_from;
  if (!h.instrument.empty())
    body["instrument"] = instrument_json(h.device, h.instrument, h.instrument_checked_on.value_or(utc_today()));
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
  if (const auto it = m.find("instrument"); it != m.end() && it->is_object()) {
    h.instrument = read_instrument(*it);
    h.instrument_checked_on = date(*it, "checked_on");
  }
  return h;
}

bool is_header_key(std::string_view key) {
  static constexpr std::string_view keys[] = {"class",     "session", "kind",          "device",     "samples",
                                              "recording", "derived", "replayed_from", "instrument", "recording_error"};
  for (const std::string_view k : keys)
    if (k == key) return true;
  return false;
}

}  // namespace guideway::results
