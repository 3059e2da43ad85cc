// What the fleet refuses at ingest (payload_check.hpp): payloads too large, too deep, or of the wrong shape.
#include "fleet/payload_check.hpp"

#include "fleet/headlines.hpp"
#include "results/explanation.hpp"
#include "results/params.hpp"

namespace guideway::fleet {

namespace {

using nlohmann::json;

// Why `j[key]`, when present, is not of the kind `is` accepts ("" when absent or right).
template <typename Is>
std::string field_problem(const json& j, const char* key, const char* expected, Is is) {
  const auto it = j.find(key);
  if (it == j.end() || is(*it)) return {};
  return "\"" + std::string(key) + "\" is " + std::string(it->type_name()) + ", expected " + expected;
}

bool is_text(const json& v) { return v.is_string(); }

// The first problem of several checks, in order.
std::string first_of(std::initializer_list<std::string> problems) {
  for (const auto& p : problems)
    if (!p.empty()) return p;
  return {};
}

std::string status_problem(const json& j) {
  const auto state = j.find("state");
  if (state == j.end() || !state->is_string() || (*state != "online" && *state != "offline"))
    return "a status needs \"state\": \"online\" or \"offline\"";
  return first_of({field_problem(j, "since", "a UTC time text", is_text),
                   field_problem(j, "release", "a text", is_text), field_problem(j, "reason", "a text", is_text)});
}

// What explanation_from_json refuses: a finding without its effect, a field of the wrong type.
std::string explain_problem(const json& j) {
  try {
    (void)results::explanation_from_json(j);
  } catch (const results::ExplanationFormatError& e) {
    return e.what();
  }
  return {};
}

// What params_from_json refuses (a figure whose value is not a number, a plane that is not a text), a plane
// that is not two axis letters, a headline figure that is not finite.
std::string params_problem(std::string_view kind, const json& j) {
  results::Params params;
  try {
    params = results::params_from_json(j);
  } catch (const results::ParamsFormatError& e) {
    return e.what();
  }
  if (j.contains("plane") && !is_plane(params.plane))
    return "\"plane\" is " + json(params.plane).dump().substr(0, 40) +
           ", expected two of the axis letters x, y, z (\"xy\", \"zx\", ...)";
  return figure_problem(kind, params);
}

}  // namespace

bool is_plane(std::string_view plane) {
  const auto axis = [](char c) { return c == 'x' || c == 'y' || c == 'z'; };
  return plane.size() == 2 && axis(plane[0]) && axis(plane[1]) && plane[0] != plane[1];
}

std::string payload_size_problem(std::string_view payload, std::size_t max_payload_bytes) {
  if (payload.size() > max_payload_bytes)
    return "a payload of " + std::to_string(payload.size()) + " bytes, over the fleet's maximum of " +
           std::to_string(max_payload_bytes);
  std::size_t depth = 0;
  bool in_string = false, escaped = false;
  for (const char c : payload) {
    if (in_string) {
      if (escaped)
        escaped = false;
      else if (c == '\\')
        escaped = true;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_json_depth) return "a payload nested deeper than " + std::to_string(max_json_depth) + " levels";
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return {};
}

std::string payload_problem(plant::TopicLeaf leaf, std::string_view kind, const json& j) {
  if (!j.is_object()) return "the payload is " + std::string(j.type_name()) + ", not a JSON object";
  const std::string common =
      first_of({field_problem(j, "machine", "a text", is_text), field_problem(j, "session", "a text", is_text),
                field_problem(j, "class", "a text", is_text)});
  if (!common.empty()) return common;
  switch (leaf) {
    case plant::TopicLeaf::status:
      return status_problem(j);
    case plant::TopicLeaf::params:
      return params_problem(kind, j);
    case plant::TopicLeaf::explain:
      return explain_problem(j);
    case plant::TopicLeaf::event:
    case plant::TopicLeaf::devices:
      return {};
  }
  return {};
}

}  // namespace guideway::fleet
