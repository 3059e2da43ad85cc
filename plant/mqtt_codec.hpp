#pragma once
// The MQTT 5 packets a subscribing client sends and receives, as bytes: pure encoders and decoders
// (no I/O), shared by the fleet's client (plant/mqtt_inbox.hpp) and its fuzz test. Only the subset a
// subscriber needs: CONNECT, SUBSCRIBE, PUBACK, PINGREQ, DISCONNECT out; CONNACK, SUBACK, PUBLISH,
// PUBACK, PINGRESP, DISCONNECT in. Thread safe (no shared state).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace guideway::plant {

enum class MqttPacketType : std::uint8_t {
  connect = 1,
  connack = 2,
  publish = 3,
  puback = 4,
  pubrec = 5,
  pubrel = 6,
  pubcomp = 7,
  subscribe = 8,
  suback = 9,
  unsubscribe = 10,
  unsuback = 11,
  pingreq = 12,
  pingresp = 13,
  disconnect = 14,
  auth = 15,
};
std::string_view to_string(MqttPacketType type) noexcept;

// A packet that breaks the protocol (a malformed length, a property of the wrong packet, a string that
// runs past the end, a packet over the agreed maximum size). `reason_code` is the MQTT 5 DISCONNECT
// reason a client sends about it (0x81 malformed packet, 0x82 protocol error, 0x95 packet too large).
class MqttProtocolError : public std::runtime_error {
 public:
  MqttProtocolError(std::uint8_t reason_code, const std::string& what)
      : std::runtime_error(what), reason_code_(reason_code) {}
  [[nodiscard]] std::uint8_t reason_code() const noexcept { return reason_code_; }

 private:
  std::uint8_t reason_code_;
};

inline constexpr std::uint8_t mqtt_malformed_packet = 0x81;
inline constexpr std::uint8_t mqtt_protocol_error = 0x82;
inline constexpr std::uint8_t mqtt_packet_too_large = 0x95;

struct MqttConnectRequest {
  std::string client_id;
  std::string username;  // "" = none
  std::string password;  // sent only with a username
  std::uint16_t keepalive_s = 30;
  bool clean_start = false;
  std::uint32_t session_expiry_s = 0;
  std::uint16_t receive_maximum = 0;      // 0: not sent (the protocol's default, 65535)
  std::uint32_t maximum_packet_size = 0;  // 0: not sent (no limit)
};
[[nodiscard]] std::string encode_connect(const MqttConnectRequest& request);
// One topic filter, options: maximum QoS (0..2), nothing else.
[[nodiscard]] std::string encode_subscribe(std::uint16_t packet_id, std::string_view filter, int max_qos);
[[nodiscard]] std::string encode_puback(std::uint16_t packet_id);
[[nodiscard]] std::string encode_pingreq();
[[nodiscard]] std::string encode_disconnect(std::uint8_t reason_code);

// One received packet: its type, the fixed header's low four bits, and what follows the length.
struct MqttPacket {
  MqttPacketType type = MqttPacketType::connect;
  std::uint8_t flags = 0;
  std::string body;
};

// Splits a byte stream into packets. Throws MqttProtocolError on a malformed remaining length or a
// packet larger than `max_packet_bytes` (the whole packet, as MQTT 5 counts it).
class MqttPacketReader {
 public:
  explicit MqttPacketReader(std::size_t max_packet_bytes) : max_packet_bytes_(max_packet_bytes) {}
  void feed(std::string_view bytes) { buffer_.append(bytes); }
  // The next complete packet, or nullopt until more bytes are fed.
  std::optional<MqttPacket> next();
  [[nodiscard]] std::size_t buffered() const noexcept { return buffer_.size() - start_; }

 private:
  std::size_t max_packet_bytes_;
  std::string buffer_;
  std::size_t start_ = 0;
};

struct MqttConnack {
  bool session_present = false;
  std::uint8_t reason_code = 0;  // 0 = accepted
  std::string reason_string;
  std::string assigned_client_id;
  std::optional<std::uint16_t> server_keepalive_s;
  std::optional<std::uint16_t> receive_maximum;
  std::optional<std::uint32_t> maximum_packet_size;
  std::optional<std::uint32_t> session_expiry_s;
  std::optional<std::uint8_t> maximum_qos;
};
struct MqttSuback {
  std::uint16_t packet_id = 0;
  std::vector<std::uint8_t> reason_codes;  // one per filter: the granted QoS, or >= 0x80 refused
  std::string reason_string;
};
struct MqttPublish {
  std::string topic;
  int qos = 0;
  bool dup = false;
  bool retain = false;
  std::uint16_t packet_id = 0;  // QoS > 0 only
  std::vector<std::pair<std::string, std::string>> user_properties;
  std::string payload;
  [[nodiscard]] std::string_view user_property(std::string_view name) const;  // "" when absent
};
struct MqttPuback {
  std::uint16_t packet_id = 0;
  std::uint8_t reason_code = 0;
};
struct MqttDisconnect {
  std::uint8_t reason_code = 0;
  std::string reason_string;
};

// Each throws MqttProtocolError when the packet is not a well-formed one of its type.
[[nodiscard]] MqttConnack decode_connack(const MqttPacket& packet);
[[nodiscard]] MqttSuback decode_suback(const MqttPacket& packet);
[[nodiscard]] MqttPublish decode_publish(const MqttPacket& packet);
[[nodiscard]] MqttPuback decode_puback(const MqttPacket& packet);
[[nodiscard]] MqttDisconnect decode_disconnect(const MqttPacket& packet);

// For tests and tools that play the broker's side: a PUBLISH (QoS 0 or 1) and a CONNACK as a broker
// sends them.
[[nodiscard]] std::string encode_publish(const MqttPublish& publish);
[[nodiscard]] std::string encode_connack(bool session_present, std::uint8_t reason_code);

}  // namespace guideway::plant
