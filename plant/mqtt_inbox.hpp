#pragma once
// An MQTT 5 subscriber that acknowledges a QoS 1 message only after its owner has stored it: the
// messages that arrive are handed over in batches to a store callback, and their PUBACKs go to the
// broker only when that callback returns (committed). A store that fails (a full disk, a locked
// database) acknowledges nothing: the batch is retried with back-off while the connection is kept, and
// if the process dies the broker still holds every unacknowledged message of the persistent session and
// sends it again on the next connection. libmosquitto and Paho C both acknowledge before their message
// callback runs, which is why the fleet has this client of its own (docs/plant.md, "Delivery").
// Speaks plain TCP or TLS (plant/mqtt_socket.hpp). Not thread safe: one thread runs it.

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "plant/mqtt_connection.hpp"

namespace guideway::plant {

struct InboxMessage {
  std::string topic;
  std::string payload;
  std::string produced_utc;  // the "produced_utc" user property, "" when absent
  int qos = 0;
  bool redelivered = false;  // the broker's DUP flag: it may have been stored already
};

struct InboxSettings {
  ConnectionSettings connection;              // session_expiry_s > 0: a persistent session (the fleet)
  std::string filter;                         // one topic filter, subscribed with QoS 1
  std::uint16_t receive_maximum = 100;        // QoS 1 messages unacknowledged at once: the largest batch
  std::uint32_t max_message_bytes = 1 << 20;  // a larger message is never sent (MQTT 5 Maximum Packet Size)
  int connect_timeout_ms = 10000;
  double store_retry_max_s = 30.0;  // a failing store is retried after 1 s, doubling up to this
};

struct InboxCounts {
  std::uint64_t received = 0;
  std::uint64_t acknowledged = 0;
  std::uint64_t store_failures = 0;  // batches the store refused (retried, not acknowledged)
  std::uint64_t qos0_dropped = 0;    // QoS 0 messages dropped while the store was failing
};

class MqttInbox {
 public:
  // Stores every message of `batch` durably, or throws std::exception saying why (nothing of the batch
  // is then acknowledged). A message the store decides never to keep (malformed, ...) counts as stored:
  // it is acknowledged, so that the broker does not send it forever.
  using StoreBatch = std::function<void(const std::vector<InboxMessage>& batch)>;
  using Log = std::function<void(const std::string& line)>;

  MqttInbox(InboxSettings settings, Log log);

  // One connection: connects, subscribes, receives and stores until `stop` is set (checked every
  // 100 ms; then a clean DISCONNECT and "") or the connection ends (why: "connection refused", "the
  // broker refused the login: Not authorized", ...). `connected()` says whether the broker accepted it.
  std::string run_connection(const std::atomic<bool>& stop, const StoreBatch& store);

  [[nodiscard]] bool accepted() const noexcept { return accepted_; }
  [[nodiscard]] const InboxCounts& counts() const noexcept { return counts_; }

 private:
  InboxSettings settings_;
  Log log_;
  InboxCounts counts_;
  bool accepted_ = false;
};

}  // namespace guideway::plant
