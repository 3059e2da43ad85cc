#pragma once
// The messages guidewayd publishes (docs/protocol.md), encoded once where they are made; their classes and
// the one place a "class" is written are results/message_class.hpp. Requests are parsed in protocol.hpp.

#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "results/message_class.hpp"

namespace guideway::daemon {

// A published message on its way to watchers, encoded once where it is made (SAMPLEs on the pipeline
// thread, not on the event loop).
struct Message {
  results::MessageClass cls = results::MessageClass::event;
  std::string channel;  // the device it is about ("" = none)
  std::string session;  // the session it is about ("" = none): its watchers by name get it too
  nlohmann::json body;  // the object, kept for PARAMS, EXPLAIN and EVENT (the daemon answers and reads them); else null
  std::string line;     // the encoded object, no newline
  bool device_news = false;  // an EVENT of what happened inside a device, not a change of state (Event)
  // A PARAMS or EXPLAIN: its session's kind and (a traverse's PARAMS) its axis, what the daemon keeps the newest
  // result by (set where the message is made, from the session and its types).
  std::string kind{};
  std::string axis{};
};

Message make_message(results::MessageClass cls, nlohmann::json body, std::string channel = {},
                     std::string session = {});

// An EVENT: what happened to a device, an emulator or a session. Empty fields are left out.
struct Event {
  std::string event{};  // "streaming", "lost", "emulator_exited", "session_failed", "report_ready", ...
  std::string time{};   // UTC ISO 8601 (device and emulator events)
  std::string device{};
  std::string emulator{};
  std::string session{};
  std::string reason{};  // why (a failure): the daemon logs events with a reason as warnings
  std::string file{};    // the file it produced (report_ready)
  // What happened inside a device (a CANopen node's EMCY, boot, loss), not a change of its state nor a
  // session's news: the MQTT journal drops these first and rate-limits them per device (docs/plant.md).
  bool device_news = false;
};

Message make_message(const Event& event);

}  // namespace guideway::daemon
