#pragma once
// The classes of the messages of the protocol (docs/protocol.md) and the one place a message's "class"
// is written: the requests a client sends (version, status, ...), the replies to one client (VERSION,
// ERROR, ...), the classes published to watchers (STATUS, SAMPLE, PARAMS, EXPLAIN, EVENT) and the CLI's
// own PORT lines. The daemon, replay, the CLI and the fleet name a class through these enums, never by
// its text. Pure; thread safe.

#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace guideway::results {

// Replies to one client, then the classes published to watchers (is_published), then `guideway ports`'s.
enum class MessageClass {
  version,
  error,
  watch,
  session,
  report,
  recordings,
  status,
  sample,
  params,
  explain,
  event,
  port
};

std::string_view to_string(MessageClass cls) noexcept;  // the wire name: "STATUS", "PARAMS", ...
[[nodiscard]] bool is_published(MessageClass cls) noexcept;
// The class named `name` ("PARAMS"), published or not; nullopt for an unknown name.
std::optional<MessageClass> class_named(std::string_view name) noexcept;
// The published class named `name` ("PARAMS"); nullopt for a reply-only or unknown name.
std::optional<MessageClass> published_class(std::string_view name) noexcept;
std::string published_class_names();  // "STATUS, SAMPLE, PARAMS, EXPLAIN, EVENT", for error messages

// `body` (a JSON object) with its class set: every reply and published message is made here.
nlohmann::json with_class(MessageClass cls, nlohmann::json body);
// Whether `message` is an object whose "class" is `cls`.
[[nodiscard]] bool has_class(const nlohmann::json& message, MessageClass cls);

// What a client asks, in the order docs/protocol.md lists them; the wire name is lower case.
enum class RequestClass { version, status, poll, watch, start, stop, params, explain, report, recordings };

std::string_view to_string(RequestClass cls) noexcept;  // "version", "status", ...
std::optional<RequestClass> request_named(std::string_view name) noexcept;
std::string request_class_names();  // "version, status, poll, ...", for error messages
// A request of class `cls`: `body` with its "class" set.
nlohmann::json request(RequestClass cls, nlohmann::json body = nlohmann::json::object());

}  // namespace guideway::results
