#pragma once
// `guideway fleet serve`: subscribes to every machine's topics on the plant's broker and stores every
// status, PARAMS, EXPLAIN and EVENT in the fleet's database (fleet/store.hpp). A persistent MQTT
// session (the broker queues QoS 1 messages while the fleet is away), reconnect with back-off.

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

#include "fleet/store.hpp"
#include "plant/mqtt_connection.hpp"

namespace guideway::fleet {

struct SubscriberSettings {
  plant::ConnectionSettings connection;  // session_expiry_s > 0: a persistent session
  std::string topic_prefix = "guideway";
  double reconnect_max_s = 60.0;
};

struct SubscriberCounts {
  std::uint64_t stored = 0;
  std::uint64_t duplicates = 0;  // retained copies seen again, QoS 1 redeliveries
  std::uint64_t ignored = 0;     // not of the tree, not JSON, ...
};

class Subscriber {
 public:
  using Log = std::function<void(const std::string& line)>;
  Subscriber(SubscriberSettings settings, Store& store, Log log);
  // Runs until `stop` is set (checked every 100 ms).
  void run(const std::atomic<bool>& stop);
  [[nodiscard]] const SubscriberCounts& counts() const { return counts_; }

 private:
  void on_message(std::string_view topic, std::string_view payload, std::string_view produced_utc);

  SubscriberSettings settings_;
  Store& store_;
  Log log_;
  SubscriberCounts counts_;
  bool connected_ = false;
  bool subscribe_ = false;  // connected: subscribe on the next turn of the loop
};

}  // namespace guideway::fleet
