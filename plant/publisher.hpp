#pragma once
// A daemon's MQTT publisher (docs/plant.md): the daemon hands it PARAMS, EXPLAIN and EVENTs, which go
// to the broker in the order they were made, QoS 1, through the on-disk journal (plant/message_journal.hpp),
// and the device table, QoS 0, latest only. Each message has its share of the journal: results are never
// dropped for events, and a device's events are rate-limited (plant/event_rate_limit.hpp). Everything that touches the
// network or the disk runs on the publisher's own thread: publish() only appends to a list under a mutex, so a broker
// that is down, slow or refusing never delays the caller (the event loop). The status topic says online while connected
// and the broker's will says offline when the daemon dies.

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>

#include <spdlog/logger.h>

#include "core/backoff.hpp"
#include "plant/event_rate_limit.hpp"
#include "plant/message_journal.hpp"
#include "plant/mqtt_connection.hpp"
#include "plant/topics.hpp"

namespace guideway::plant {

struct PublisherSettings {
  ConnectionSettings connection;
  std::string machine;  // the topic level that names this machine tool
  std::string topic_prefix = "guideway";
  std::string journal_dir;  // where unacknowledged messages wait (STATE_DIR/mqtt-journal)
  std::size_t queue_max_messages = 10000;
  std::size_t queue_max_bytes = 64u << 20;
  double queue_events_percent = 25.0;  // the part of both bounds events may take
  double events_per_minute = 60.0;     // a device's events journaled a minute at most, after a burst of as many
  // The EVENT that says how many events of `device` were held back by its rate (its payload); none when unset.
  std::function<std::string(const std::string& device, std::uint64_t count)> held_back_event;
  std::string release;           // the daemon's version, in the online status
  double reconnect_min_s = 1.0;  // back-off between connection attempts: doubles up to max
  double reconnect_max_s = 60.0;
};

// What STATUS shows of the publisher.
struct PublisherStats {
  std::string broker;                 // mqtt://host:port
  std::string state;                  // connecting | connected | disconnected | refused
  std::string since;                  // UTC, when it entered that state
  std::string last_error;             // why the last connection failed or ended ("" = none yet)
  std::uint64_t queued = 0;           // waiting for the broker (in the journal, and handed over)
  std::uint64_t delivered = 0;        // acknowledged by the broker
  std::uint64_t dropped = 0;          // every message dropped: the four below, unreadable ones, failed writes
  std::uint64_t dropped_results = 0;  // dropped to keep the journal within its bounds, by share
  std::uint64_t dropped_transitions = 0;
  std::uint64_t dropped_events = 0;
  std::uint64_t rate_limited = 0;  // events held back by their device's rate
  std::uint64_t refused = 0;       // refused by the broker (its ACL, a reason code >= 0x80), too large for it, or
                                   // not acknowledged on 5 connections: given up, not retried
  std::uint64_t reconnects = 0;    // successful connections after the first
};

class Publisher {
 public:
  // Opens the journal (throws std::runtime_error when its directory is unusable) and starts the thread.
  Publisher(PublisherSettings settings, std::shared_ptr<spdlog::logger> log);
  // Publishes the offline status, gives the journal a short time to drain, disconnects.
  ~Publisher();
  Publisher(const Publisher&) = delete;
  Publisher& operator=(const Publisher&) = delete;

  // PARAMS and EXPLAIN (`leaf`; retained, under their kind): QoS 1, journaled as results, in order.
  void publish(TopicLeaf leaf, std::string_view kind, std::string payload);
  // An EVENT: QoS 1, journaled in `share`, in order with the rest. Events of the share `events` are
  // rate-limited per `device`.
  void publish_event(std::string payload, JournalShare share, std::string_view device);
  // The device table: QoS 0, sent only while connected; a newer one replaces one not yet sent.
  void publish_devices(std::string payload);
  [[nodiscard]] PublisherStats stats() const;
  [[nodiscard]] const PublisherSettings& settings() const { return settings_; }

 private:
  void run();
  void hand_over(JournalEntry entry);  // under mutex_
  void take_handed_over();
  void send_next();
  void on_connected(int reason_code, const std::string& why);
  void on_disconnected(const std::string& why);
  void on_published(int mid, int reason_code);
  void set_state(const std::string& state, const std::string& error);
  void refuse_front(const std::string& why);  // gives up the journal's oldest message, counted as refused
  void finish_front(bool delivered);          // the oldest message is done: delivered or refused
  void count_queue();                         // stats_.queued and .dropped from their sources; under mutex_
  [[nodiscard]] std::string status_payload(bool online, const std::string& reason) const;
  void drain_before_exit();

  PublisherSettings settings_;
  std::shared_ptr<spdlog::logger> log_;
  std::string started_utc_;

  mutable std::mutex mutex_;  // guards the hand-over lists, stop_ and stats_
  std::condition_variable wake_;
  std::deque<JournalEntry> handed_over_;
  std::string devices_;  // latest device table not yet sent ("" = none)
  bool stop_ = false;
  PublisherStats stats_;
  std::uint64_t not_written_ = 0;   // dropped before the journal: a failed write
  JournalDrops not_handed_over_{};  // dropped before the journal, by share: the hand-over's overflow
  EventRateLimit rate_limit_;

  // The publisher thread's own state.
  std::unique_ptr<MessageJournal> journal_;
  std::unique_ptr<MqttConnection> connection_;
  bool connected_ = false;
  bool up_ = false;         // connect() started and loop() has not failed since
  int inflight_mid_ = -1;   // the journal's front, sent and not yet acknowledged
  int front_attempts_ = 0;  // times the journal's front has been sent
  bool announce_online_ = false;
  bool stopping_ =
      false;  // disconnecting at shutdown: not a lost connection  // a new connection: the online status goes first
  int status_mid_ = -1;
  bool status_acked_ = false;
  Backoff backoff_;
  std::int64_t reconnect_at_ns_ = 0;
  std::uint64_t connections_ = 0;
  std::string last_logged_error_;
  std::thread thread_;
};

}  // namespace guideway::plant
