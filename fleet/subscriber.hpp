#pragma once
// `guideway fleet serve`: subscribes to every machine's topics on the plant's broker and stores every
// status, PARAMS, EXPLAIN and EVENT in the fleet's database (fleet/store.hpp). A persistent MQTT
// session, and a message is acknowledged to the broker only once it is committed (plant/mqtt_inbox.hpp):
// a crash, a full disk or a locked database loses nothing the broker handed over. Reconnects with
// back-off. Not thread safe: run() on one thread.

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
  std::size_t max_payload_bytes = default_max_payload_bytes;
  std::uint16_t batch_max = 100;  // messages in flight and committed together
};

struct SubscriberCounts {
  std::uint64_t stored = 0;
  std::uint64_t duplicates = 0;      // retained copies seen again, QoS 1 redeliveries
  std::uint64_t ignored = 0;         // superseded (a status older than the one stored)
  std::uint64_t refused = 0;         // malformed: counted in the database's refusals, never stored
  std::uint64_t store_failures = 0;  // batches the database could not take (retried, not acknowledged)
};

class Subscriber {
 public:
  using Log = std::function<void(const std::string& line)>;
  Subscriber(SubscriberSettings settings, Store& store, Log log);
  // Runs until `stop` is set (checked every 100 ms); then disconnects cleanly.
  void run(const std::atomic<bool>& stop);
  [[nodiscard]] const SubscriberCounts& counts() const { return counts_; }

 private:
  SubscriberSettings settings_;
  Store& store_;
  Log log_;
  SubscriberCounts counts_;
};

}  // namespace guideway::fleet
