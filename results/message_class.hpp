#pragma once
// The classes of the messages guidewayd sends (docs/protocol.md) and the one place a message's "class"
// is written: replies to one client (VERSION, ERROR, ...) and the classes published to watchers
// (STATUS, SAMPLE, PARAMS, EXPLAIN, EVENT). The daemon, replay, the CLI and the fleet name a class
// through MessageClass, never by its text. Pure; thread safe.

#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace guideway::results {

// Replies to one client, then the classes published to watchers (is_published).
enum class MessageClass { version, error, watch, session, report, recordings, status, sample, params, explain, event };

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

}  // namespace guideway::results
