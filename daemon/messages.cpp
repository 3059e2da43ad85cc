#include "daemon/messages.hpp"

#include <array>
#include <utility>

namespace guideway::daemon {

namespace {

struct ClassName {
  MessageClass cls;
  std::string_view name;
  bool published;
};

constexpr std::array class_names = {
    ClassName{MessageClass::version, "VERSION", false},     ClassName{MessageClass::error, "ERROR", false},
    ClassName{MessageClass::watch, "WATCH", false},         ClassName{MessageClass::session, "SESSION", false},
    ClassName{MessageClass::report, "REPORT", false},       ClassName{MessageClass::recordings, "RECORDINGS", false},
    ClassName{MessageClass::status, "STATUS", true},        ClassName{MessageClass::sample, "SAMPLE", true},
    ClassName{MessageClass::params, "PARAMS", true},        ClassName{MessageClass::explain, "EXPLAIN", true},
    ClassName{MessageClass::event, "EVENT", true},
};

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

std::optional<MessageClass> published_class(std::string_view name) noexcept {
  for (const ClassName& c : class_names) {
    if (c.published && c.name == name) return c.cls;
  }
  return std::nullopt;
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

Message make_message(MessageClass cls, nlohmann::json body, std::string channel, std::string session) {
  Message m{cls, std::move(channel), std::move(session), with_class(cls, std::move(body)), {}};
  m.line = m.body.dump();
  if (cls != MessageClass::params && cls != MessageClass::explain && cls != MessageClass::event) m.body = nullptr;
  return m;
}

Message make_message(const Event& e) {
  nlohmann::json j = {{"event", e.event}};
  const std::pair<const char*, const std::string*> fields[] = {{"time", &e.time},         {"device", &e.device},
                                                               {"emulator", &e.emulator}, {"session", &e.session},
                                                               {"reason", &e.reason},     {"file", &e.file}};
  for (const auto& [key, value] : fields) {
    if (!value->empty()) j[key] = *value;
  }
  return make_message(MessageClass::event, std::move(j), e.device, e.session);
}

}  // namespace guideway::daemon
