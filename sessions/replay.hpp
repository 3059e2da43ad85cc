#pragma once
// Replay of a session's raw recording (guideway/raw/1, docs/formats.md): the samples go through the
// session kind that made the recording exactly as the daemon fed them live (the same SessionKind and
// identification code, the raw samples), so the result is the PARAMS the live session published. Like gpsd's gpsfake,
// it makes every live result reproducible and regression-testable offline.

#include <cstdint>
#include <optional>
#include <stop_token>
#include <string>
#include <utility>
#include <vector>

#include "results/explanation.hpp"
#include "results/params.hpp"
#include "results/result_header.hpp"
#include "sessions/session.hpp"

namespace guideway::sessions {

// The device of a recording (or of a session identified in a process of its own, daemon/session_analysis.hpp):
// its name, driver and channels, what a session is created with; never started.
class RecordedDevice : public drivers::Driver {
 public:
  RecordedDevice(std::string name, std::string driver, std::vector<drivers::ChannelInfo> channels)
      : Driver(std::move(name), std::move(driver), std::move(channels), 2) {}

 protected:
  void run(std::stop_token) override {}
};

// What the live session published, as types: whoever sends it on writes the messages (results::to_json,
// with_header, with_class), as the daemon does.
struct ReplayResult {
  // The PARAMS' header: session, kind, device, samples, `replayed_from`, the instrument judged on the day the
  // session started. An EXPLAIN's is the same without `samples` (it names its session, not what it was fed).
  results::ResultHeader header;
  std::optional<results::Params> parameters;        // the identified parameters; none when identification failed
  std::optional<results::Explanation> explanation;  // none when the kind has no explanation or it failed
  std::string explain_failure;                      // why the explanation failed (the live explain_failed reason)
  std::string failure;                   // why identification failed (the live session's session_failed reason)
  std::size_t samples = 0;               // samples replayed
  bool complete = true;                  // false: a .part, no `# end =` trailer, `end = aborted`, or samples lost
  std::string end_marker;                // the trailer's `end` (complete, aborted), "" when there is none
  std::uint64_t samples_lost = 0;        // the trailer's `samples_lost`: rows the recorder could not write
  std::size_t dropped_partial_line = 0;  // 1 when a last line without its newline was ignored (a kill)
  std::string note;  // why the result may differ from the live one (a recording of an older release)
};

// Throws std::runtime_error "file:line: message" for a file that is not a raw recording, a session
// kind this build does not know, or options the kind refuses.
ReplayResult replay_recording(const std::string& path, const SessionRegistry& registry);

}  // namespace guideway::sessions
