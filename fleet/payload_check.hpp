#pragma once
// What the fleet refuses at ingest (docs/plant.md, "What is refused"): a payload too large or too deeply
// nested to read safely, a payload that is not a JSON object, and an object whose fields the fleet's
// readers rely on have the wrong type (a finding whose effect is not a text, a plane that is not two
// axis letters, ...). A refused message is counted and logged, never stored, so that one bad result
// can never stop `fleet status`, `history` or `report`. Pure; thread safe.

#include <cstddef>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "plant/topics.hpp"

namespace guideway::fleet {

// The largest payload stored (bytes); `fleet serve` also tells the broker never to send a larger one.
inline constexpr std::size_t default_max_payload_bytes = 1 << 20;
// Brackets deeper than this are refused before parsing (a reader's recursion stays bounded).
inline constexpr std::size_t max_json_depth = 64;

// Why `payload` cannot be parsed safely ("" when it can): its size or its nesting.
[[nodiscard]] std::string payload_size_problem(std::string_view payload, std::size_t max_payload_bytes);

// Why a parsed payload of topic leaf `leaf` (and session kind `kind`) cannot be stored ("" when it can):
// the fields the fleet reads must have the documented types (docs/protocol.md).
[[nodiscard]] std::string payload_problem(plant::TopicLeaf leaf, std::string_view kind, const nlohmann::json& payload);

// A DBB plane as PARAMS name it: two different letters of x, y, z ("xy", "zx", ...).
[[nodiscard]] bool is_plane(std::string_view plane);

}  // namespace guideway::fleet
