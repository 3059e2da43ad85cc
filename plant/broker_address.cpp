// The MQTT broker's address (broker_address.hpp): mqtt:// or mqtts://, host and port.
#include "plant/broker_address.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <stdexcept>

#include "core/printable.hpp"

namespace guideway::plant {

std::string BrokerAddress::url() const {
  const bool bracket = host.find(':') != std::string::npos;  // an IPv6 literal
  return std::string(tls ? "mqtts://" : "mqtt://") + (bracket ? "[" + host + "]" : host) + ":" + std::to_string(port);
}

BrokerAddress parse_broker_url(std::string_view url) {
  const auto fail = [&](const std::string& why) {
    throw std::invalid_argument("\"" + printable(url) + "\": " + why +
                                " (expected mqtt://HOST[:PORT] or mqtts://HOST[:PORT], e.g. mqtt://broker.plant:1883)");
  };
  BrokerAddress a;
  std::string_view rest;
  if (url.starts_with("mqtt://")) {
    rest = url.substr(7);
  } else if (url.starts_with("mqtts://")) {
    rest = url.substr(8);
    a.tls = true;
    a.port = 8883;
  } else {
    fail("unknown scheme");
  }
  if (!rest.empty() && rest.back() == '/') rest.remove_suffix(1);
  if (rest.find_first_of("/?#@") != std::string_view::npos)
    fail("no path, query or user part here (credentials go in username and password_file)");
  std::string_view port_text;
  const bool bracketed = rest.starts_with("[");
  if (bracketed) {  // [IPv6]:port
    const auto close = rest.find(']');
    if (close == std::string_view::npos) fail("unterminated '[' in the host");
    a.host = std::string(rest.substr(1, close - 1));
    rest = rest.substr(close + 1);
    if (!rest.empty()) {
      if (rest.front() != ':') fail("expected ':' after ']'");
      port_text = rest.substr(1);
      if (port_text.empty()) fail("empty port");
    }
  } else {
    const auto colon = rest.rfind(':');
    a.host = std::string(rest.substr(0, colon));
    if (colon != std::string_view::npos) {
      port_text = rest.substr(colon + 1);
      if (port_text.empty()) fail("empty port");
    }
  }
  if (a.host.empty()) fail("no host");
  const auto bad_char = [&](std::string_view allowed_extra) {
    return std::find_if(a.host.begin(), a.host.end(), [&](char c) {
             return !std::isalnum(static_cast<unsigned char>(c)) && allowed_extra.find(c) == std::string_view::npos;
           }) != a.host.end();
  };
  if (bracketed) {
    if (bad_char(":.%") || a.host.find(':') == std::string::npos) fail("not an IPv6 address between '[' and ']'");
  } else if (a.host.find(':') != std::string::npos) {
    fail("an IPv6 address goes between brackets (mqtt://[::1]:1883)");
  } else if (bad_char(".-_")) {
    fail("a host name has letters, digits, '.', '-' and '_' only");
  }
  if (!port_text.empty()) {
    int port = 0;
    const auto [end, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
    if (ec != std::errc() || end != port_text.data() + port_text.size() || port < 1 || port > 65535)
      fail("the port must be a number from 1 to 65535");
    a.port = port;
  }
  return a;
}

}  // namespace guideway::plant
