#pragma once
// The MQTT topic tree a plant's daemons publish under (docs/plant.md, docs/protocol.md "MQTT"):
//   PREFIX/MACHINE/status          {"state":"online"|"offline",...}   retained, QoS 1 (the will sets offline)
//   PREFIX/MACHINE/params/KIND     the PARAMS object                   retained, QoS 1
//   PREFIX/MACHINE/explain/KIND    the EXPLAIN object                  retained, QoS 1
//   PREFIX/MACHINE/event           every EVENT                         QoS 1
//   PREFIX/MACHINE/devices         STATUS's time and device table      QoS 0, every status_period_s

#include <optional>
#include <string>
#include <string_view>

namespace guideway::plant {

enum class TopicLeaf { status, params, explain, event, devices };

std::string_view to_string(TopicLeaf leaf) noexcept;  // "status", "params", ...

// A topic of the tree, taken apart.
struct Topic {
  std::string machine;
  TopicLeaf leaf = TopicLeaf::status;
  std::string kind;  // params and explain: the session kind ("dbb", "runout", ...); else ""
};

// PREFIX/MACHINE/LEAF[/KIND]. `kind` is used by params and explain only.
std::string topic_for(std::string_view prefix, std::string_view machine, TopicLeaf leaf, std::string_view kind = {});
// The topic taken apart, or nullopt when it is not one of the tree under `prefix`.
std::optional<Topic> parse_topic(std::string_view prefix, std::string_view topic);
// The subscriptions that receive the whole tree of every machine under `prefix` (PREFIX/+/status, ...).
std::string subscription_filter(std::string_view prefix);  // "PREFIX/#"

// Why `name` cannot be one level of a topic (a machine name, a session kind) or a prefix ("" when it
// can): empty, longer than max_topic_level_bytes (a prefix: max_topic_prefix_bytes), contains '+',
// '#', a control character or bytes that are not UTF-8, or (a level) contains '/'.
inline constexpr std::size_t max_topic_level_bytes = 128;
inline constexpr std::size_t max_topic_prefix_bytes = 256;
std::string topic_level_problem(std::string_view name);
std::string topic_prefix_problem(std::string_view prefix);
// Why `id` cannot be an MQTT client identifier here ("" when it can): empty, over 256 bytes, a control
// character or not UTF-8.
std::string client_id_problem(std::string_view id);

}  // namespace guideway::plant
