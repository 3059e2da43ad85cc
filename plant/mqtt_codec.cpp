// MQTT 5 packets of a subscribing client as bytes (mqtt_codec.hpp): pure encoders and decoders.
#include "plant/mqtt_codec.hpp"

#include <array>

#include "core/printable.hpp"

namespace guideway::plant {

namespace {

// MQTT 5 property identifiers (section 2.2.2.2) this code reads or writes.
enum Property : std::uint8_t {
  payload_format_indicator = 0x01,
  message_expiry_interval = 0x02,
  content_type = 0x03,
  response_topic = 0x08,
  correlation_data = 0x09,
  subscription_identifier = 0x0B,
  session_expiry_interval = 0x11,
  assigned_client_identifier = 0x12,
  server_keep_alive = 0x13,
  authentication_method = 0x15,
  authentication_data = 0x16,
  response_information = 0x1A,
  server_reference = 0x1C,
  reason_string = 0x1F,
  receive_maximum = 0x21,
  topic_alias_maximum = 0x22,
  topic_alias = 0x23,
  maximum_qos = 0x24,
  retain_available = 0x25,
  user_property = 0x26,
  maximum_packet_size = 0x27,
  wildcard_subscription_available = 0x28,
  subscription_identifier_available = 0x29,
  shared_subscription_available = 0x2A,
};

enum class PropertyType { byte, two, four, varint, string, binary, pair };

std::optional<PropertyType> type_of(std::uint8_t id) {
  switch (id) {
    case payload_format_indicator:
    case maximum_qos:
    case retain_available:
    case wildcard_subscription_available:
    case subscription_identifier_available:
    case shared_subscription_available:
      return PropertyType::byte;
    case server_keep_alive:
    case receive_maximum:
    case topic_alias_maximum:
    case topic_alias:
      return PropertyType::two;
    case message_expiry_interval:
    case session_expiry_interval:
    case maximum_packet_size:
      return PropertyType::four;
    case subscription_identifier:
      return PropertyType::varint;
    case content_type:
    case response_topic:
    case assigned_client_identifier:
    case authentication_method:
    case response_information:
    case server_reference:
    case reason_string:
      return PropertyType::string;
    case correlation_data:
    case authentication_data:
      return PropertyType::binary;
    case user_property:
      return PropertyType::pair;
    default:
      return std::nullopt;
  }
}

[[noreturn]] void malformed(const std::string& what) { throw MqttProtocolError(mqtt_malformed_packet, what); }

// Well-formed UTF-8 without U+0000, as MQTT requires of every string (section 1.5.4).
bool valid_mqtt_utf8(std::string_view s) {
  for (std::size_t i = 0; i < s.size();) {
    const std::size_t n = utf8_sequence_length(s, i);
    if (n == 0 || s[i] == '\0') return false;
    i += n;
  }
  return true;
}

// Reads the fields of a packet body in order; every read past the end is a malformed packet.
class Cursor {
 public:
  Cursor(std::string_view body, const char* packet) : s_(body), packet_(packet) {}
  [[nodiscard]] bool done() const { return at_ == s_.size(); }
  [[nodiscard]] std::size_t left() const { return s_.size() - at_; }
  std::uint8_t byte() {
    need(1, "a byte");
    return static_cast<std::uint8_t>(s_[at_++]);
  }
  std::uint16_t two() {
    need(2, "a two-byte integer");
    const auto v = static_cast<std::uint16_t>((static_cast<unsigned char>(s_[at_]) << 8) |
                                              static_cast<unsigned char>(s_[at_ + 1]));
    at_ += 2;
    return v;
  }
  std::uint32_t four() {
    const std::uint32_t hi = two();
    return (hi << 16) | two();
  }
  std::uint32_t varint() {
    std::uint32_t value = 0;
    for (int shift = 0; shift < 28; shift += 7) {
      const std::uint8_t b = byte();
      value |= static_cast<std::uint32_t>(b & 0x7F) << shift;
      if ((b & 0x80) == 0) return value;
    }
    malformed(std::string(packet_) + ": a variable byte integer longer than 4 bytes");
  }
  std::string_view binary() {
    const std::uint16_t n = two();
    need(n, "a string or binary field of " + std::to_string(n) + " bytes");
    const auto v = s_.substr(at_, n);
    at_ += n;
    return v;
  }
  std::string string(const char* what) {
    const auto v = binary();
    if (!valid_mqtt_utf8(v)) malformed(std::string(packet_) + ": " + what + " is not valid UTF-8 (or holds U+0000)");
    return std::string(v);
  }
  std::string_view rest() {
    const auto v = s_.substr(at_);
    at_ = s_.size();
    return v;
  }
  // A property block: calls `each(id, cursor_over_value)` for each property, after checking its type.
  template <typename Each>
  void properties(Each&& each) {
    const std::uint32_t length = varint();
    need(length, "a property block of " + std::to_string(length) + " bytes");
    Cursor block(s_.substr(at_, length), packet_);
    at_ += length;
    while (!block.done()) {
      const std::uint8_t id = static_cast<std::uint8_t>(block.varint());
      if (!type_of(id)) malformed(std::string(packet_) + ": unknown property 0x" + hex(id));
      each(id, block);
    }
  }
  [[noreturn]] void fail(const std::string& what) const { malformed(std::string(packet_) + ": " + what); }

  static std::string hex(std::uint8_t v) {
    static constexpr char digits[] = "0123456789abcdef";
    return {digits[v >> 4], digits[v & 15]};
  }

 private:
  void need(std::size_t n, const std::string& what) const {
    if (left() < n) malformed(std::string(packet_) + ": " + what + " runs past the end of the packet");
  }
  std::string_view s_;
  std::size_t at_ = 0;
  const char* packet_;
};

// Skips the value of a property the caller does not use.
void skip(std::uint8_t id, Cursor& c) {
  switch (*type_of(id)) {
    case PropertyType::byte:
      c.byte();
      break;
    case PropertyType::two:
      c.two();
      break;
    case PropertyType::four:
      c.four();
      break;
    case PropertyType::varint:
      c.varint();
      break;
    case PropertyType::string:
      c.string("a property");
      break;
    case PropertyType::binary:
      c.binary();
      break;
    case PropertyType::pair:
      c.string("a user property's name");
      c.string("a user property's value");
      break;
  }
}

class Writer {
 public:
  Writer& byte(std::uint8_t v) {
    s_.push_back(static_cast<char>(v));
    return *this;
  }
  Writer& two(std::uint16_t v) { return byte(static_cast<std::uint8_t>(v >> 8)).byte(static_cast<std::uint8_t>(v)); }
  Writer& four(std::uint32_t v) { return two(static_cast<std::uint16_t>(v >> 16)).two(static_cast<std::uint16_t>(v)); }
  Writer& varint(std::uint32_t v) {
    do {
      std::uint8_t b = v & 0x7F;
      v >>= 7;
      if (v != 0) b |= 0x80;
      byte(b);
    } while (v != 0);
    return *this;
  }
  Writer& string(std::string_view v) {
    if (v.size() > 0xFFFF) throw std::invalid_argument("an MQTT string of more than 65535 bytes");
    two(static_cast<std::uint16_t>(v.size()));
    s_.append(v);
    return *this;
  }
  Writer& raw(std::string_view v) {
    s_.append(v);
    return *this;
  }
  [[nodiscard]] const std::string& bytes() const { return s_; }

 private:
  std::string s_;
};

// A whole packet: fixed header (type, flags, remaining length) and `body`.
std::string packet(MqttPacketType type, std::uint8_t flags, const std::string& body) {
  Writer w;
  w.byte(static_cast<std::uint8_t>((static_cast<unsigned>(type) << 4) | flags));
  w.varint(static_cast<std::uint32_t>(body.size()));
  w.raw(body);
  return w.bytes();
}

std::string with_properties(const Writer& props) {
  Writer w;
  w.varint(static_cast<std::uint32_t>(props.bytes().size())).raw(props.bytes());
  return w.bytes();
}

void expect(const MqttPacket& p, MqttPacketType type) {
  if (p.type != type)
    throw MqttProtocolError(mqtt_protocol_error,
                            "expected " + std::string(to_string(type)) + ", got " + std::string(to_string(p.type)));
}

}  // namespace

std::string_view to_string(MqttPacketType type) noexcept {
  static constexpr std::array<std::string_view, 16> names = {
      "reserved",  "CONNECT", "CONNACK",     "PUBLISH",  "PUBACK",  "PUBREC",   "PUBREL",     "PUBCOMP",
      "SUBSCRIBE", "SUBACK",  "UNSUBSCRIBE", "UNSUBACK", "PINGREQ", "PINGRESP", "DISCONNECT", "AUTH"};
  return names[static_cast<std::size_t>(type) & 15];
}

std::string encode_connect(const MqttConnectRequest& r) {
  Writer props;
  if (r.session_expiry_s != 0) props.byte(session_expiry_interval).four(r.session_expiry_s);
  if (r.receive_maximum != 0) props.byte(receive_maximum).two(r.receive_maximum);
  if (r.maximum_packet_size != 0) props.byte(maximum_packet_size).four(r.maximum_packet_size);
  Writer w;
  w.string("MQTT").byte(5);
  std::uint8_t flags = r.clean_start ? 0x02 : 0x00;
  if (!r.username.empty()) flags = static_cast<std::uint8_t>(flags | 0x80 | (r.password.empty() ? 0 : 0x40));
  w.byte(flags).two(r.keepalive_s).raw(with_properties(props));
  w.string(r.client_id);
  if (!r.username.empty()) {
    w.string(r.username);
    if (!r.password.empty()) w.string(r.password);  // binary data: the same two-byte length and bytes
  }
  return packet(MqttPacketType::connect, 0, w.bytes());
}

std::string encode_subscribe(std::uint16_t packet_id, std::string_view filter, int max_qos) {
  Writer w;
  w.two(packet_id).varint(0).string(filter).byte(static_cast<std::uint8_t>(max_qos & 3));
  return packet(MqttPacketType::subscribe, 0x2, w.bytes());
}

std::string encode_puback(std::uint16_t packet_id) {
  Writer w;
  w.two(packet_id);  // reason 0 (success) and no properties: the short form
  return packet(MqttPacketType::puback, 0, w.bytes());
}

std::string encode_pingreq() { return packet(MqttPacketType::pingreq, 0, {}); }

std::string encode_disconnect(std::uint8_t reason_code) {
  if (reason_code == 0) return packet(MqttPacketType::disconnect, 0, {});
  Writer w;
  w.byte(reason_code).varint(0);
  return packet(MqttPacketType::disconnect, 0, w.bytes());
}

std::string encode_publish(const MqttPublish& p) {
  Writer props;
  for (const auto& [name, value] : p.user_properties) props.byte(user_property).string(name).string(value);
  Writer w;
  w.string(p.topic);
  if (p.qos > 0) w.two(p.packet_id);
  w.raw(with_properties(props)).raw(p.payload);
  const auto flags = static_cast<std::uint8_t>((p.dup ? 0x8 : 0) | ((p.qos & 3) << 1) | (p.retain ? 0x1 : 0));
  return packet(MqttPacketType::publish, flags, w.bytes());
}

std::string encode_connack(bool session_present, std::uint8_t reason_code) {
  Writer w;
  w.byte(session_present ? 1 : 0).byte(reason_code).varint(0);
  return packet(MqttPacketType::connack, 0, w.bytes());
}

std::optional<MqttPacket> MqttPacketReader::next() {
  const std::string_view s = std::string_view(buffer_).substr(start_);
  if (s.size() < 2) return std::nullopt;
  std::uint32_t length = 0;
  std::size_t header = 1;
  for (int shift = 0;; shift += 7) {
    if (shift == 28) malformed("a remaining length longer than 4 bytes");
    if (header >= s.size()) return std::nullopt;
    const auto b = static_cast<std::uint8_t>(s[header++]);
    length |= static_cast<std::uint32_t>(b & 0x7F) << shift;
    if ((b & 0x80) == 0) break;
  }
  if (header + length > max_packet_bytes_)
    throw MqttProtocolError(mqtt_packet_too_large, "a packet of " + std::to_string(header + length) +
                                                       " bytes, over the maximum of " +
                                                       std::to_string(max_packet_bytes_));
  if (s.size() < header + length) return std::nullopt;
  const auto first = static_cast<std::uint8_t>(s[0]);
  MqttPacket p{static_cast<MqttPacketType>(first >> 4), static_cast<std::uint8_t>(first & 0x0F),
               std::string(s.substr(header, length))};
  start_ += header + length;
  if (start_ == buffer_.size()) {
    buffer_.clear();
    start_ = 0;
  } else if (start_ > 65536 && start_ > buffer_.size() / 2) {  // keep the buffer from growing without end
    buffer_.erase(0, start_);
    start_ = 0;
  }
  if (static_cast<unsigned>(first >> 4) == 0) malformed("packet type 0 is reserved");
  return p;
}

MqttConnack decode_connack(const MqttPacket& p) {
  expect(p, MqttPacketType::connack);
  Cursor c(p.body, "CONNACK");
  MqttConnack a;
  const std::uint8_t flags = c.byte();
  if ((flags & 0xFE) != 0) c.fail("reserved acknowledge flags set");
  a.session_present = (flags & 1) != 0;
  a.reason_code = c.byte();
  if (c.done()) return a;  // no property block: allowed only when the server has nothing to say
  c.properties([&](std::uint8_t id, Cursor& v) {
    switch (id) {
      case reason_string:
        a.reason_string = v.string("the reason string");
        break;
      case assigned_client_identifier:
        a.assigned_client_id = v.string("the assigned client identifier");
        break;
      case server_keep_alive:
        a.server_keepalive_s = v.two();
        break;
      case receive_maximum:
        a.receive_maximum = v.two();
        break;
      case maximum_packet_size:
        a.maximum_packet_size = v.four();
        break;
      case session_expiry_interval:
        a.session_expiry_s = v.four();
        break;
      case maximum_qos:
        a.maximum_qos = v.byte();
        break;
      default:
        skip(id, v);
        break;
    }
  });
  if (!c.done()) c.fail("bytes after the properties");
  return a;
}

MqttSuback decode_suback(const MqttPacket& p) {
  expect(p, MqttPacketType::suback);
  Cursor c(p.body, "SUBACK");
  MqttSuback s;
  s.packet_id = c.two();
  c.properties([&](std::uint8_t id, Cursor& v) {
    if (id == reason_string)
      s.reason_string = v.string("the reason string");
    else
      skip(id, v);
  });
  while (!c.done()) s.reason_codes.push_back(c.byte());
  if (s.reason_codes.empty()) c.fail("no reason code");
  return s;
}

MqttPublish decode_publish(const MqttPacket& p) {
  expect(p, MqttPacketType::publish);
  Cursor c(p.body, "PUBLISH");
  MqttPublish m;
  m.dup = (p.flags & 0x8) != 0;
  m.qos = (p.flags >> 1) & 3;
  m.retain = (p.flags & 1) != 0;
  if (m.qos == 3) c.fail("QoS 3");
  m.topic = c.string("the topic");
  if (m.topic.empty()) c.fail("an empty topic (topic aliases were not allowed)");
  if (m.topic.find_first_of("+#") != std::string::npos) c.fail("a wildcard in a topic name");
  if (m.qos > 0) {
    m.packet_id = c.two();
    if (m.packet_id == 0) c.fail("packet identifier 0");
  }
  c.properties([&](std::uint8_t id, Cursor& v) {
    if (id == topic_alias) c.fail("a topic alias (this client allows none)");
    if (id == user_property) {
      std::string name = v.string("a user property's name");
      std::string value = v.string("a user property's value");
      m.user_properties.emplace_back(std::move(name), std::move(value));
    } else {
      skip(id, v);
    }
  });
  m.payload = std::string(c.rest());
  return m;
}

MqttPuback decode_puback(const MqttPacket& p) {
  expect(p, MqttPacketType::puback);
  Cursor c(p.body, "PUBACK");
  MqttPuback a;
  a.packet_id = c.two();
  if (!c.done()) a.reason_code = c.byte();
  if (!c.done()) c.properties([](std::uint8_t id, Cursor& v) { skip(id, v); });
  return a;
}

MqttDisconnect decode_disconnect(const MqttPacket& p) {
  expect(p, MqttPacketType::disconnect);
  Cursor c(p.body, "DISCONNECT");
  MqttDisconnect d;
  if (c.done()) return d;
  d.reason_code = c.byte();
  if (c.done()) return d;
  c.properties([&](std::uint8_t id, Cursor& v) {
    if (id == reason_string)
      d.reason_string = v.string("the reason string");
    else
      skip(id, v);
  });
  return d;
}

std::string_view MqttPublish::user_property(std::string_view name) const {
  for (const auto& [n, v] : user_properties)
    if (n == name) return v;
  return {};
}

}  // namespace guideway::plant
