#pragma once
// One MQTT v5 client connection (libmosquitto), driven by the caller's thread: connect() starts
// connecting without blocking on the network, loop() does the network work and runs the callbacks on
// the calling thread. Used by the daemon's publisher (plant/publisher.hpp) and by `guideway fleet serve`.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "plant/broker_address.hpp"

struct mosquitto;

namespace guideway::plant {

struct ConnectionSettings {
  BrokerAddress broker;
  std::string ca_file;    // TLS: the CA certificate that signed the broker's ("" = the system's, /etc/ssl/certs)
  std::string cert_file;  // TLS client certificate and its key (both or neither)
  std::string key_file;
  std::string username;   // "" = anonymous
  std::string password;   // read from a password file by whoever made the settings, never from a config
  std::string client_id;
  int keepalive_s = 30;
  // 0: a clean session (the daemon: its journal keeps what is unsent). > 0: the broker keeps the
  // session and queues QoS 1 messages for it this long while the client is away (the fleet).
  std::uint32_t session_expiry_s = 0;
  struct Will {
    std::string topic;
    std::string payload;
    bool retain = true;
  };
  std::optional<Will> will;  // QoS 1
};

class MqttConnection {
 public:
  static constexpr int never_sendable = -2;
  struct Callbacks {
    std::function<void(int reason_code, const std::string& why)> connected;  // 0 = accepted
    std::function<void(const std::string& why)> disconnected;                // the connection ended
    std::function<void(int mid, int reason_code)> published;                 // QoS 1: the broker's PUBACK
    // A message received; produced_utc is its "produced_utc" user property ("" when it has none).
    std::function<void(std::string_view topic, std::string_view payload, std::string_view produced_utc)> message;
  };

  // Throws std::runtime_error when libmosquitto refuses the settings (a TLS file it cannot read, ...).
  MqttConnection(ConnectionSettings settings, Callbacks callbacks);
  ~MqttConnection();
  MqttConnection(const MqttConnection&) = delete;
  MqttConnection& operator=(const MqttConnection&) = delete;

  // Starts (or restarts) connecting; "" or why it could not start. With session_expiry_s it blocks
  // until the broker answers (the fleet has nothing else to do).
  std::string connect();
  // Network work: waits up to timeout_ms for the network or a wake(), then does what is ready; "" while
  // the connection is up or coming up, else why it is not.
  std::string loop(int timeout_ms);
  // Ends a loop()'s wait now (thread safe): a message was handed over to the thread that runs loop().
  void wake() noexcept;
  // Sends (QoS 0 or 1) with the "produced_utc" user property when given; the message id, or with
  // `error` set: -1 when it may go later (not connected), `never_sendable` when this message can never
  // go (over the broker's maximum packet size, a topic or payload the protocol refuses).
  int publish(const std::string& topic, std::string_view payload, int qos, bool retain, std::string_view produced_utc,
              std::string& error);
  bool subscribe(const std::string& filter, int qos, std::string& error);
  void disconnect();
  [[nodiscard]] const ConnectionSettings& settings() const { return settings_; }

 private:
  ConnectionSettings settings_;
  Callbacks callbacks_;
  mosquitto* mosq_ = nullptr;
  bool started_ = false;
  int wake_fd_ = -1;  // eventfd
};

// The password in `path` (its first line). Throws std::runtime_error when the file cannot be read, is
// empty, or can be read by every user (the daemon's and the fleet's rule: chmod 0600 or 0640).
std::string read_password_file(const std::string& path);

// libmosquitto's text for an error code (MOSQ_ERR_*), and for an MQTT v5 reason code.
std::string mosquitto_error_text(int rc);
std::string mqtt_reason_text(int reason_code);

}  // namespace guideway::plant
