// The MQTT topic tree (topics.hpp): topics made and parsed, names checked.
#include "plant/topics.hpp"

#include <array>

#include "core/printable.hpp"

namespace guideway::plant {

namespace {
constexpr std::array<std::string_view, 5> leaf_names = {"status", "params", "explain", "event", "devices"};
}  // namespace

std::string_view to_string(TopicLeaf leaf) noexcept { return leaf_names[static_cast<std::size_t>(leaf)]; }

std::string topic_for(std::string_view prefix, std::string_view machine, TopicLeaf leaf, std::string_view kind) {
  std::string t;
  t.reserve(prefix.size() + machine.size() + kind.size() + 16);
  t.append(prefix).append("/").append(machine).append("/").append(to_string(leaf));
  if (leaf == TopicLeaf::params || leaf == TopicLeaf::explain) t.append("/").append(kind);
  return t;
}

std::optional<Topic> parse_topic(std::string_view prefix, std::string_view topic) {
  if (topic.size() <= prefix.size() + 1 || !topic.starts_with(prefix) || topic[prefix.size()] != '/')
    return std::nullopt;
  std::string_view rest = topic.substr(prefix.size() + 1);
  const auto slash = rest.find('/');
  if (slash == std::string_view::npos || slash == 0) return std::nullopt;
  Topic t;
  t.machine = std::string(rest.substr(0, slash));
  rest = rest.substr(slash + 1);
  const auto next = rest.find('/');
  const std::string_view leaf = rest.substr(0, next);
  std::size_t i = 0;
  while (i < leaf_names.size() && leaf_names[i] != leaf) ++i;
  if (i == leaf_names.size()) return std::nullopt;
  t.leaf = static_cast<TopicLeaf>(i);
  const bool has_kind = t.leaf == TopicLeaf::params || t.leaf == TopicLeaf::explain;
  if (has_kind) {
    if (next == std::string_view::npos) return std::nullopt;
    t.kind = std::string(rest.substr(next + 1));
    if (!topic_level_problem(t.kind).empty()) return std::nullopt;
  } else if (next != std::string_view::npos) {
    return std::nullopt;
  }
  return t;
}

std::string subscription_filter(std::string_view prefix) { return std::string(prefix) + "/#"; }

namespace {

// Why `text` cannot go into an MQTT string a person reads ("" when it can): a control character (NUL
// included: MQTT forbids it) or bytes that are not UTF-8.
std::string text_problem(std::string_view text) {
  if (printable(text) != text) return "must not contain control characters or bytes that are not UTF-8";
  return {};
}

}  // namespace

std::string topic_level_problem(std::string_view name) {
  if (name.empty()) return "must not be empty";
  if (name.size() > max_topic_level_bytes)
    return "is " + std::to_string(name.size()) + " bytes long; at most " + std::to_string(max_topic_level_bytes);
  if (name.find('/') != std::string_view::npos) return "must not contain '/' (it is one level of the topic)";
  return topic_prefix_problem(name);
}

std::string client_id_problem(std::string_view id) {
  if (id.empty()) return "must not be empty";
  if (id.size() > 256) return "is " + std::to_string(id.size()) + " bytes long; at most 256";
  return text_problem(id);
}

std::string topic_prefix_problem(std::string_view prefix) {
  if (prefix.empty()) return "must not be empty";
  if (prefix.size() > max_topic_prefix_bytes)
    return "is " + std::to_string(prefix.size()) + " bytes long; at most " + std::to_string(max_topic_prefix_bytes);
  if (prefix.find_first_of("+#") != std::string_view::npos) return "must not contain MQTT wildcards ('+', '#')";
  if (prefix.find('\0') != std::string_view::npos) return "must not contain a NUL byte";
  if (std::string p = text_problem(prefix); !p.empty()) return p;
  if (prefix.front() == '/' || prefix.back() == '/') return "must not begin or end with '/'";
  if (prefix.find("//") != std::string_view::npos) return "must not contain an empty level ('//')";
  return {};
}

}  // namespace guideway::plant
