#pragma once
// Where the MQTT broker is: mqtt://HOST[:PORT] (plain, default port 1883) or mqtts://HOST[:PORT]
// (TLS, default port 8883).

#include <string>
#include <string_view>

namespace guideway::plant {

struct BrokerAddress {
  std::string host;
  int port = 1883;
  bool tls = false;
  [[nodiscard]] std::string url() const;  // as written back: mqtts://host:port
};

// Throws std::invalid_argument saying what is wrong and what is expected.
BrokerAddress parse_broker_url(std::string_view url);

}  // namespace guideway::plant
