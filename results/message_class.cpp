// The protocol's message classes (message_class.hpp): the one place a message's "class" is written and recognised.
#include "results/message_class.hpp"

#include <array>

namespace guideway::results {

namespace {

struct ClassName {
  MessageClass cls;
  std::string_view name;
  bool published;
};

constexpr std::array class_names = {
    ClassName{MessageClass::version, "VERSION", false}, ClassName{MessageClass::error, "ERROR", false},
    ClassName{MessageClass::watch, "WATCH", false},     ClassName{MessageClass::session, "SESSION", false},
    ClassName{MessageClass::report, "REPORT", false},   ClassName{MessageClass::recordings, "RECORDINGS", false},
    ClassName{MessageClass::status, "STATUS", true},    ClassName{MessageClass::sample, "SAMPLE", true},
    ClassName{MessageClass::params, "PARAMS", true},    ClassName{MessageClass::explain, "EXPLAIN", true},
    ClassName{MessageClass::event, "EVENT", true},      ClassName{MessageClass::port, "PORT", false},
};

struct RequestName {
  RequestClass cls;
  std::string_view name;
};

constexpr std::array request_names = {
    RequestName{RequestClass::version, "version"}, RequestName{RequestClass::status, "status"},
    RequestName{RequestClass::poll, "poll"},       RequestName{RequestClass::watch, "watch"},
    RequestName{RequestClass::start, "start"},     RequestName{RequestClass::stop, "stop"},
    RequestName{RequestClass::params, "params"},   RequestName{RequestClass::explain, "explain"},
    RequestName{RequestClass::report, "report"},   RequestName{RequestClass::recordings, "recordings"},
};
static_assert([] {
  for (std::size_t i = 0; i < request_names.size(); ++i) {
    if (static_cast<std::size_t>(request_names[i].cls) != i) return false;
  }
  return true;
}());

// Indexed by the enum: the table lists the classes in its order.
static_assert([] {
  for (std::size_t i = 0; i < class_names.size(); ++i) {
    if (static_cast<std::size_t>(class_names[i].cls) != i) return false;
  }
  return true;
}());

const ClassName& entry(MessageClass cls) noexcept { return class_names[static_cast<std::size_t>(cls)]; }

}  // namespace

std::string_view to_string(MessageClass cls) noexcept { return entry(cls).name; }

bool is_published(MessageClass cls) noexcept { return entry(cls).published; }

std::optional<MessageClass> class_named(std::string_view name) noexcept {
  for (const ClassName& c : class_names) {
    if (c.name == name) return c.cls;
  }
  return std::nullopt;
}

std::optional<MessageClass> published_class(std::string_view name) noexcept {
  const auto cls = class_named(name);
  return cls && is_published(*cls) ? cls : std::nullopt;
}

std::string published_class_names() {
  std::string out;
  for (const ClassName& c : class_names) {
    if (c.published) out += (out.empty() ? "" : ", ") + std::string(c.name);
  }
  return out;
}

nlohmann::json with_class(MessageClass cls, nlohmann::json body) {
  body["class"] = to_string(cls);
  return body;
}

std::string_view to_string(RequestClass cls) noexcept { return request_names[static_cast<std::size_t>(cls)].name; }

std::optional<RequestClass> request_named(std::string_view name) noexcept {
  for (const RequestName& r : request_names) {
    if (r.name == name) return r.cls;
  }
  return std::nullopt;
}

std::string request_class_names() {
  std::string out;
  for (const RequestName& r : request_names) out += (out.empty() ? "" : ", ") + std::string(r.name);
  return out;
}

nlohmann::json request(RequestClass cls, nlohmann::json body) {
  body["class"] = to_string(cls);
  return body;
}

bool has_class(const nlohmann::json& message, MessageClass cls) {
  if (!message.is_object()) return false;
  const auto it = message.find("class");
  return it != message.end() && it->is_string() && it->get_ref<const std::string&>() == to_string(cls);
}

}  // namespace guideway::results
