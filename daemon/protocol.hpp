#pragma once
// The JSON Lines protocol of guidewayd (docs/protocol.md): one JSON object per line, every object
// carries "class". Requests use lower-case classes ("status"), replies and published messages
// upper-case ("STATUS"). Fields that are unknown are left out, never null.

#include <optional>
#include <set>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "daemon/messages.hpp"

namespace guideway::daemon {

inline constexpr int protocol_major = 1;
// Minor versions only add: 1 added STATUS devices[].driver_counters; 3 added the DBB ranking and notes
// in PARAMS, the findings' contributions in EXPLAIN and dbb-can's bus_off counter.
inline constexpr int protocol_minor = 7;

nlohmann::json version_message();
nlohmann::json error_message(std::string_view message, std::string_view request_class = {});

struct Request {
  std::string cls;  // lower-cased
  nlohmann::json body;
  std::optional<nlohmann::json> id;  // echoed in the reply when given
};

// Why a request line was refused, and its "id" when it had one (echoed in the ERROR).
struct RequestError {
  std::string message;
  std::optional<nlohmann::json> id;
};

// Parses one request line (without its newline); on failure returns nullopt and sets `error`. An empty
// or blank line and a line with a NUL byte are refused like any other that is not one JSON object.
std::optional<Request> parse_request(std::string_view line, RequestError& error);

// What a client asked to receive with `watch`.
struct Subscription {
  bool enabled = false;
  std::set<results::MessageClass> classes;      // empty = every published class except SAMPLE
  std::set<std::string, std::less<>> channels;  // empty = every device/session
  // `channel`: the device a message is about; `session`: the session it is about ("" = none). Either
  // name in `channels` lets it through.
  [[nodiscard]] bool wants(results::MessageClass cls, std::string_view channel, std::string_view session = {}) const;
};

// Applies a watch request; returns the reply (WATCH) or throws std::invalid_argument with the reason.
nlohmann::json apply_watch(const nlohmann::json& body, Subscription& sub);

}  // namespace guideway::daemon
