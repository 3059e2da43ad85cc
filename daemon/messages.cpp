// The messages guidewayd publishes, each encoded once where it is made (messages.hpp).
#include "daemon/messages.hpp"

#include <utility>

namespace guideway::daemon {

Message make_message(results::MessageClass cls, nlohmann::json body, std::string channel, std::string session) {
  using results::MessageClass;
  Message m{cls, std::move(channel), std::move(session), results::with_class(cls, std::move(body)), {}};
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
  Message m = make_message(results::MessageClass::event, std::move(j), e.device, e.session);
  m.device_news = e.device_news;
  return m;
}

}  // namespace guideway::daemon
