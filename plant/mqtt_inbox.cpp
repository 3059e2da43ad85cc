// An MQTT 5 subscriber that acknowledges a message only once it is stored (mqtt_inbox.hpp).
#include "plant/mqtt_inbox.hpp"

#include <algorithm>
#include <chrono>
#include <exception>
#include <optional>
#include <string_view>
#include <utility>

#include "core/backoff.hpp"
#include "plant/mqtt_codec.hpp"
#include "plant/mqtt_socket.hpp"

namespace guideway::plant {

namespace {

using Clock = std::chrono::steady_clock;

constexpr int write_timeout_ms = 10000;
constexpr std::uint16_t subscribe_packet_id = 1;
// QoS 0 messages (the device tables) kept beside a batch the store is refusing; more are dropped.
constexpr std::size_t qos0_pending_max = 1000;

std::string reason_text(std::uint8_t code, const std::string& reason_string) {
  std::string text = mqtt_reason_text(code);
  if (!reason_string.empty()) text += " (" + reason_string + ")";
  return text;
}

// The messages received and not yet stored, with the packet identifiers to acknowledge once they are.
struct Pending {
  std::vector<InboxMessage> messages;
  std::vector<std::uint16_t> packet_ids;  // QoS 1, in the order received
  std::size_t qos0 = 0;
};

// One connection's state: the socket, the packet stream and the keep-alive.
class Session {
 public:
  Session(const InboxSettings& s, InboxCounts& counts, const std::atomic<bool>& stop)
      : settings_(s),
        counts_(counts),
        socket_(s.connection, s.connect_timeout_ms, &stop),
        reader_(s.max_message_bytes),
        keepalive_(std::chrono::seconds(std::max(1, s.connection.keepalive_s))) {}

  // CONNECT and CONNACK; "" or why the broker did not accept.
  std::string handshake() {
    MqttConnectRequest r;
    r.client_id = settings_.connection.client_id;
    r.username = settings_.connection.username;
    r.password = settings_.connection.password;
    r.keepalive_s = static_cast<std::uint16_t>(std::clamp(settings_.connection.keepalive_s, 1, 65535));
    r.clean_start = settings_.connection.session_expiry_s == 0;
    r.session_expiry_s = settings_.connection.session_expiry_s;
    r.receive_maximum = settings_.receive_maximum;
    r.maximum_packet_size = settings_.max_message_bytes;
    send(encode_connect(r));
    const auto deadline = Clock::now() + std::chrono::milliseconds(settings_.connect_timeout_ms);
    for (;;) {
      if (auto p = reader_.next()) {
        if (p->type == MqttPacketType::disconnect) {
          const auto d = decode_disconnect(*p);
          return "the broker refused the connection: " + reason_text(d.reason_code, d.reason_string);
        }
        const auto a = decode_connack(*p);
        if (a.reason_code != 0)
          return "the broker refused the connection: " + reason_text(a.reason_code, a.reason_string);
        if (a.server_keepalive_s && *a.server_keepalive_s > 0) keepalive_ = std::chrono::seconds(*a.server_keepalive_s);
        session_present_ = a.session_present;
        return {};
      }
      const int left =
          static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count());
      if (left <= 0) return "no CONNACK from the broker within " + std::to_string(settings_.connect_timeout_ms) + " ms";
      reader_.feed(socket_.read_some(left));  // ends within 100 ms of a stop (SocketStopped)
    }
  }

  void subscribe(std::string_view filter) { send(encode_subscribe(subscribe_packet_id, filter, 1)); }

  // Reads what arrives within timeout_ms and takes the complete packets apart; "" or why the
  // connection must end.
  std::string receive(int timeout_ms, Pending& pending, bool store_failing) {
    const std::string bytes = socket_.read_some(timeout_ms);
    if (!bytes.empty()) last_received_ = Clock::now();
    reader_.feed(bytes);
    while (auto p = reader_.next()) {
      switch (p->type) {
        case MqttPacketType::publish: {
          auto m = decode_publish(*p);
          if (m.qos > 1) {
            throw MqttProtocolError(mqtt_protocol_error, "a QoS 2 PUBLISH on a QoS 1 subscription");
          }
          ++counts_.received;
          if (m.qos == 0) {
            if (store_failing && pending.qos0 >= qos0_pending_max) {
              ++counts_.qos0_dropped;
              break;
            }
            ++pending.qos0;
          } else {
            pending.packet_ids.push_back(m.packet_id);
          }
          pending.messages.push_back(
              {std::move(m.topic), std::move(m.payload), std::string(m.user_property("produced_utc")), m.qos, m.dup});
          break;
        }
        case MqttPacketType::suback: {
          const auto s = decode_suback(*p);
          if (s.packet_id == subscribe_packet_id && !s.reason_codes.empty() && s.reason_codes.front() >= 0x80)
            return "the broker refused the subscription: " + reason_text(s.reason_codes.front(), s.reason_string);
          if (s.packet_id == subscribe_packet_id && !subscribed_) {
            subscribed_ = true;
            just_subscribed_ = true;
          }
          break;
        }
        case MqttPacketType::pingresp:
          ping_sent_.reset();
          break;
        case MqttPacketType::disconnect: {
          const auto d = decode_disconnect(*p);
          return "the broker disconnected: " + reason_text(d.reason_code, d.reason_string);
        }
        default:
          throw MqttProtocolError(mqtt_protocol_error,
                                  "an unexpected " + std::string(to_string(p->type)) + " from the broker");
      }
    }
    return {};
  }

  // "" or why the broker is considered gone (no PINGRESP within the keep-alive).
  std::string keep_alive() {
    const auto now = Clock::now();
    if (ping_sent_) {
      if (now - *ping_sent_ > keepalive_) return "no PINGRESP within the keep-alive";
      return {};
    }
    if (now - last_sent_ >= keepalive_ / 2 || now - last_received_ >= keepalive_) {
      send(encode_pingreq());
      ping_sent_ = now;
    }
    return {};
  }

  void acknowledge(const std::vector<std::uint16_t>& packet_ids) {
    std::string bytes;
    for (const auto id : packet_ids) bytes += encode_puback(id);
    if (!bytes.empty()) send(bytes);
    counts_.acknowledged += packet_ids.size();
  }

  void disconnect(std::uint8_t reason) {
    try {
      send(encode_disconnect(reason));
    } catch (const std::exception&) {  // the connection is going anyway
    }
  }

  [[nodiscard]] bool session_present() const { return session_present_; }
  // True once, after the SUBACK that accepted the subscription arrived.
  bool take_subscribed() { return std::exchange(just_subscribed_, false); }

 private:
  void send(const std::string& bytes) {
    socket_.write_all(bytes, write_timeout_ms);
    last_sent_ = Clock::now();
  }

  const InboxSettings& settings_;
  InboxCounts& counts_;
  MqttSocket socket_;
  MqttPacketReader reader_;
  std::chrono::steady_clock::duration keepalive_;
  Clock::time_point last_sent_ = Clock::now();
  Clock::time_point last_received_ = Clock::now();
  std::optional<Clock::time_point> ping_sent_;
  bool session_present_ = false;
  bool subscribed_ = false;
  bool just_subscribed_ = false;
};

}  // namespace

MqttInbox::MqttInbox(InboxSettings settings, Log log) : settings_(std::move(settings)), log_(std::move(log)) {}

std::string MqttInbox::run_connection(const std::atomic<bool>& stop, const StoreBatch& store) {
  accepted_ = false;
  try {
    Session session(settings_, counts_, stop);
    if (std::string why = session.handshake(); !why.empty()) return why;
    accepted_ = true;
    session.subscribe(settings_.filter);
    log_("connected to " + settings_.connection.broker.url() + " as " + settings_.connection.client_id +
         (session.session_present() ? " (its session kept)" : " (a new session)") + "; subscribing to " +
         settings_.filter);
    Pending pending;
    Backoff retry{1.0, settings_.store_retry_max_s};
    std::optional<Clock::time_point> retry_at;  // set while the store is failing
    std::string last_failure;
    while (!stop.load()) {
      // Take in everything that is ready (up to one batch of QoS 1) before storing: one commit for many.
      int timeout_ms = pending.messages.empty() || retry_at ? 100 : 0;
      for (;;) {
        const auto before = counts_.received;
        std::string why;
        try {
          why = session.receive(timeout_ms, pending, retry_at.has_value());
        } catch (const SocketStopped&) {
          break;  // stopped while waiting: the loop ends, and the DISCONNECT below is clean
        }
        if (!why.empty()) return why;
        if (session.take_subscribed()) log_("subscribed to " + settings_.filter + " (the broker's SUBACK)");
        if (timeout_ms > 0 || counts_.received == before || pending.packet_ids.size() >= settings_.receive_maximum)
          break;
      }
      if (!pending.messages.empty() && (!retry_at || Clock::now() >= *retry_at)) {
        try {
          store(pending.messages);
          session.acknowledge(pending.packet_ids);
          pending = {};
          if (retry_at) log_("stored again: " + last_failure + " is over");
          retry_at.reset();
          last_failure.clear();
          retry.reset();
        } catch (const std::exception& e) {
          ++counts_.store_failures;
          const double wait_s = retry.take_s();
          retry_at = Clock::now() + std::chrono::milliseconds(static_cast<int>(wait_s * 1000));
          if (e.what() != last_failure) {
            log_("could not store " + std::to_string(pending.messages.size()) +
                 " message(s), none acknowledged (the broker keeps them): " + e.what() + "; trying again");
            last_failure = e.what();
          }
        }
      }
      if (std::string why = session.keep_alive(); !why.empty()) return why;
    }
    session.disconnect(0);
    return {};
  } catch (const SocketStopped&) {  // stopped while connecting, in the TLS handshake or waiting for CONNACK
    return {};
  } catch (const MqttProtocolError& e) {
    return std::string("protocol error: ") + e.what();
  } catch (const std::exception& e) {
    return e.what();
  }
}

}  // namespace guideway::plant
