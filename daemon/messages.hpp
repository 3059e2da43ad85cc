#pragma once
// The messages guidewayd sends (docs/protocol.md): their classes, and the one place a message's
// "class" is written and its JSON encoded. Requests are parsed in protocol.hpp.

#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace guideway::daemon {

// Replies to one client, then the classes published to watchers (is_published).
enum class MessageClass { version, error, watch, session, report, recordings, status, sample, params, explain, event };

std::string_view to_string(MessageClass cls) noexcept;  // the wire name: "STATUS", "PARAMS", ...
[[nodiscard]] bool is_published(MessageClass cls) noexcept;
// The published class named `name` ("PARAMS"); nullopt for a reply-only or unknown name.
std::optional<MessageClass> published_class(std::string_view name) noexcept;
std::string published_class_names();  // "STATUS, SAMPLE, PARAMS, EXPLAIN, EVENT", for error messages

// `body` (a JSON object) with its class set: every reply and published message is made here.
nlohmann::json with_class(MessageClass cls, nlohmann::json body);

// A published message on its way to watchers, encoded once where it is made (SAMPLEs on the pipeline
// thread, not on the event loop).
struct Message {
  MessageClass cls = MessageClass::event;
  std::string channel;  // the device it is about ("" = none)
  std::string session;  // the session it is about ("" = none): its watchers by name get it too
  nlohmann::json body;  // the object, kept for PARAMS, EXPLAIN and EVENT (the daemon reads them); else null
  std::string line;     // the encoded object, no newline
};

Message make_message(MessageClass cls, nlohmann::json body, std::string channel = {}, std::string session = {});

// An EVENT: what happened to a device, an emulator or a session. Empty fields are left out.
struct Event {
  std::string event{};  // "streaming", "lost", "emulator_exited", "session_failed", "report_ready", ...
  std::string time{};   // UTC ISO 8601 (device and emulator events)
  std::string device{};
  std::string emulator{};
  std::string session{};
  std::string reason{};  // why (a failure): the daemon logs events with a reason as warnings
  std::string file{};    // the file it produced (report_ready)
};

Message make_message(const Event& event);

}  // namespace guideway::daemon
