#pragma once
// The header of a result: the fields every PARAMS and EXPLAIN carries besides what was identified or
// explained (docs/protocol.md "PARAMS"): which session, of which kind, on which device, and where its
// files are. Written in one place for the daemon's live sessions and for `guideway replay`, read back by
// the CLI and the fleet. Pure; thread safe.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/instrument.hpp"

namespace guideway::results {

struct ResultHeader {
  std::string session;  // "dbb-dbb-20250101T120000Z"
  std::string kind;     // the session kind: "dbb", "straightness", ...
  std::string device;
  std::optional<std::uint64_t> samples;  // PARAMS: the samples the session was given
  std::string recording;                 // the raw recording (live sessions), "" = none
  std::string recording_error;           // why the recording is incomplete, "" = it is whole
  std::vector<std::string> derived;      // files written beside the recording
  std::string replayed_from;             // the recording a replay read, "" = a live result
  // The device's instrument (core/instrument.hpp; empty: the configuration states none) and the date its
  // calibration was judged on: the session's start (UTC), so a replay judges as the live session did.
  Instrument instrument;
  std::optional<CalendarDate> instrument_checked_on;
};

// `body` with the header's fields set; empty ones are left out (never null). A stated instrument is the
// object "instrument" (docs/protocol.md): its fields, "checked_on", and with a due date
// "calibration_expired" (plus "warning", calibration_warning's text, when it had run out).
nlohmann::json with_header(nlohmann::json body, const ResultHeader& header);
// The "instrument" object alone (STATUS's devices carry it too); null for an empty instrument.
nlohmann::json instrument_json(const std::string& device, const Instrument& instrument, const CalendarDate& checked_on);
// The header fields of a PARAMS or EXPLAIN message; absent or mistyped ones are empty.
ResultHeader read_header(const nlohmann::json& message);
// Whether `key` is one of a message's header fields (with_header's, and with_class's "class"): not its body's.
[[nodiscard]] bool is_header_key(std::string_view key);

}  // namespace guideway::results
