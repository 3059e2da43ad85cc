// A daemon's MQTT publisher thread (publisher.hpp): results and events through the journal to the broker.
#include "plant/publisher.hpp"

#include <algorithm>
#include <chrono>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/mono_clock.hpp"
#include "core/utc_time.hpp"

namespace guideway::plant {

namespace {
constexpr int loop_timeout_ms = 250;  // a wait on the network; publish() ends it (MqttConnection::wake)
constexpr double exit_drain_s = 2.0;  // at shutdown: time given to the journal, then to the offline status
constexpr int exit_loop_ms = 50;
constexpr int max_attempts_per_message = 5;  // connections a message may be sent on without an acknowledgement
}  // namespace

Publisher::Publisher(PublisherSettings settings, std::shared_ptr<spdlog::logger> log)
    : settings_(std::move(settings)),
      log_(std::move(log)),
      started_utc_(utc_now_iso()),
      rate_limit_(settings_.events_per_minute) {
  settings_.connection.will =
      ConnectionSettings::Will{topic_for(settings_.topic_prefix, settings_.machine, TopicLeaf::status),
                               status_payload(false, "connection lost"), true};
  const double events_share = std::clamp(settings_.queue_events_percent, 0.0, 100.0) / 100.0;
  journal_ = std::make_unique<MessageJournal>(
      settings_.journal_dir,
      JournalBounds{settings_.queue_max_messages, settings_.queue_max_bytes,
                    static_cast<std::size_t>(static_cast<double>(settings_.queue_max_messages) * events_share),
                    static_cast<std::size_t>(static_cast<double>(settings_.queue_max_bytes) * events_share)});
  connection_ = std::make_unique<MqttConnection>(
      settings_.connection,
      MqttConnection::Callbacks{.connected = [this](int rc, const std::string& why) { on_connected(rc, why); },
                                .disconnected = [this](const std::string& why) { on_disconnected(why); },
                                .published = [this](int mid, int rc) { on_published(mid, rc); },
                                .message = nullptr});
  backoff_ = Backoff{settings_.reconnect_min_s, settings_.reconnect_max_s};
  stats_.broker = settings_.connection.broker.url();
  stats_.state = "connecting";
  stats_.since = started_utc_;
  stats_.queued = journal_->size();
  if (journal_->taken_up() > 0)
    log_->info("MQTT: {} message(s) left unsent by the last run are queued ({})", journal_->taken_up(),
               journal_->dir());
  thread_ = std::thread([this] { run(); });
}

Publisher::~Publisher() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  connection_->wake();
  thread_.join();
}

void Publisher::publish(TopicLeaf leaf, std::string_view kind, std::string payload) {
  {
    std::lock_guard lock(mutex_);
    hand_over({topic_for(settings_.topic_prefix, settings_.machine, leaf, kind), std::move(payload), utc_now_iso_ms(),
               true, JournalShare::results});
  }
  wake_.notify_one();   // the thread waiting for a reconnect
  connection_->wake();  // the thread waiting on the network
}

void Publisher::publish_event(std::string payload, JournalShare share, std::string_view device) {
  {
    std::lock_guard lock(mutex_);
    if (share == JournalShare::events && !rate_limit_.admit(device, mono_now_ns())) {
      stats_.rate_limited = rate_limit_.held_back_total();
      return;  // counted; said in one EVENT when the device's rate allows (take_handed_over)
    }
    hand_over({topic_for(settings_.topic_prefix, settings_.machine, TopicLeaf::event), std::move(payload),
               utc_now_iso_ms(), false, share});
  }
  wake_.notify_one();
  connection_->wake();
}

void Publisher::hand_over(JournalEntry e) {
  handed_over_.push_back(std::move(e));
  // Bounded here too, should the thread be stuck (a name lookup that hangs): the oldest of the first
  // share in the order of eviction, as the journal does; counted.
  while (handed_over_.size() > settings_.queue_max_messages) {
    const auto first = std::min_element(handed_over_.begin(), handed_over_.end(),
                                        [](const JournalEntry& a, const JournalEntry& b) { return a.share < b.share; });
    ++not_handed_over_[static_cast<std::size_t>(first->share)];
    handed_over_.erase(first);
    ++stats_.dropped;
  }
  ++stats_.queued;  // recounted by the publisher's thread (count_queue), which owns the journal
}

void Publisher::publish_devices(std::string payload) {
  {
    std::lock_guard lock(mutex_);
    devices_ = std::move(payload);
  }
  connection_->wake();
}

PublisherStats Publisher::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

std::string Publisher::status_payload(bool online, const std::string& reason) const {
  nlohmann::json j = {{"state", online ? "online" : "offline"}, {"machine", settings_.machine}};
  if (online) {
    j["release"] = settings_.release;
    j["since"] = started_utc_;
  } else if (reason != "connection lost") {  // the will is written at start: it cannot know when
    j["since"] = utc_now_iso();
  }
  if (!reason.empty()) j["reason"] = reason;
  return j.dump();
}

void Publisher::set_state(const std::string& state, const std::string& error) {
  std::lock_guard lock(mutex_);
  // A refused login stays the state, with its reason, until a connection is accepted: the failed
  // connections of the retries say nothing new.
  if (stats_.state == "refused" && state != "connected" && state != "refused") return;
  if (stats_.state != state) stats_.since = utc_now_iso();
  stats_.state = state;
  if (!error.empty()) stats_.last_error = error;
}

void Publisher::take_handed_over() {
  std::deque<JournalEntry> taken;
  std::vector<EventRateLimit::HeldBack> held_back;
  {
    std::lock_guard lock(mutex_);
    taken.swap(handed_over_);
    held_back = rate_limit_.take_held_back(mono_now_ns());
  }
  for (const EventRateLimit::HeldBack& h : held_back) {
    log_->warn("MQTT: {} event(s) of device {} held back: more than {} a minute (events_per_minute)", h.count, h.source,
               settings_.events_per_minute);
    // After what was taken: those events were made before the held-back ones were counted.
    if (settings_.held_back_event)
      taken.push_back({topic_for(settings_.topic_prefix, settings_.machine, TopicLeaf::event),
                       settings_.held_back_event(h.source, h.count), utc_now_iso_ms(), false, JournalShare::events});
  }
  for (const JournalEntry& e : taken) {
    try {
      const JournalDrops dropped = journal_->push(e);
      for (std::size_t i = journal_share_count; i-- > 0;) {
        if (dropped[i] == 0) continue;
        const auto share = static_cast<JournalShare>(i);
        // A result dropped is news; an event dropped for a result is the journal doing its job.
        if (share == JournalShare::events)
          log_->debug("MQTT: journal full: {} oldest event(s) dropped", dropped[i]);
        else
          log_->warn("MQTT: journal full ({} messages, {} bytes at most): {} oldest {} dropped",
                     settings_.queue_max_messages, settings_.queue_max_bytes, dropped[i], to_string(share));
      }
    } catch (const std::exception& ex) {  // disk full: the message is lost, and said so
      log_->error("MQTT: a message for {} could not be queued: {}", e.topic, ex.what());
      std::lock_guard lock(mutex_);
      ++not_written_;
    }
  }
  std::lock_guard lock(mutex_);
  count_queue();
}

void Publisher::count_queue() {
  stats_.queued = journal_->size() + handed_over_.size();
  const auto by_share = [&](JournalShare s) {
    return journal_->dropped(s) + not_handed_over_[static_cast<std::size_t>(s)];
  };
  stats_.dropped_results = by_share(JournalShare::results);
  stats_.dropped_transitions = by_share(JournalShare::transitions);
  stats_.dropped_events = by_share(JournalShare::events);
  stats_.rate_limited = rate_limit_.held_back_total();
  stats_.dropped = stats_.dropped_results + stats_.dropped_transitions + stats_.dropped_events + stats_.rate_limited +
                   journal_->unreadable() + not_written_;
}

void Publisher::send_next() {
  {
    std::string devices;
    {
      std::lock_guard lock(mutex_);
      devices.swap(devices_);
    }
    if (!devices.empty()) {
      std::string error;
      connection_->publish(topic_for(settings_.topic_prefix, settings_.machine, TopicLeaf::devices), devices, 0, false,
                           {}, error);
    }
  }
  if (announce_online_) {
    announce_online_ = false;
    std::string error;
    status_mid_ = connection_->publish(topic_for(settings_.topic_prefix, settings_.machine, TopicLeaf::status),
                                       status_payload(true, ""), 1, true, {}, error);
  }
  if (inflight_mid_ >= 0) return;  // one at a time: the order survives any reconnect
  const std::optional<JournalEntry> e = journal_->front();
  if (!e) return;
  std::string error;
  // A message the broker never acknowledges (it drops the connection on it, say) would hold up every
  // message behind it: after a few connections it is given up, as one the broker refused.
  if (++front_attempts_ > max_attempts_per_message) {
    refuse_front("not acknowledged after " + std::to_string(max_attempts_per_message) + " connections");
    return;
  }
  const int mid = connection_->publish(e->topic, e->payload, 1, e->retain, e->produced_utc, error);
  if (mid >= 0) {
    inflight_mid_ = mid;
  } else if (mid == MqttConnection::never_sendable) {
    refuse_front(error);
  } else if (error != last_logged_error_) {  // not connected after all: tried again on the next connection
    --front_attempts_;
    last_logged_error_ = error;
    log_->warn("MQTT: could not send {}: {}", e->topic, error);
  }
}

void Publisher::refuse_front(const std::string& why) {
  const std::optional<JournalEntry> e = journal_->front();
  log_->error("MQTT: the message on {} ({} bytes) is given up: {}", e ? e->topic : "?", e ? e->payload.size() : 0, why);
  finish_front(false);
}

void Publisher::finish_front(bool delivered) {
  journal_->pop_front();
  front_attempts_ = 0;
  std::lock_guard lock(mutex_);
  ++(delivered ? stats_.delivered : stats_.refused);
  count_queue();
}

void Publisher::on_connected(int reason_code, const std::string& why) {
  if (reason_code != 0) {
    const std::string error = "the broker refused the connection: " + why;
    set_state("refused", error);
    if (error != last_logged_error_) {
      last_logged_error_ = error;
      log_->error("MQTT: {} refused the connection: {} (client id {}, user {}); trying again with back-off up to {} s",
                  settings_.connection.broker.url(), why, settings_.connection.client_id,
                  settings_.connection.username.empty() ? "anonymous" : "\"" + settings_.connection.username + "\"",
                  settings_.reconnect_max_s);
    }
    return;
  }
  connected_ = true;
  backoff_.reset();
  last_logged_error_.clear();
  inflight_mid_ = -1;       // sent again on this connection: QoS 1 may deliver twice, never out of order
  announce_online_ = true;  // sent from run(): libmosquitto holds its callback lock here
  {
    std::lock_guard lock(mutex_);
    if (++connections_ > 1) ++stats_.reconnects;
  }
  set_state("connected", "");
  log_->info("MQTT: connected to {} as {} (machine \"{}\"); {} message(s) waiting", settings_.connection.broker.url(),
             settings_.connection.client_id, settings_.machine, journal_->size());
}

void Publisher::on_disconnected(const std::string& why) {
  const bool was_connected = connected_;
  connected_ = false;
  if (stopping_) return;  // our own DISCONNECT at shutdown
  set_state("disconnected", why);
  if (was_connected) last_logged_error_ = why;
  if (was_connected)
    log_->warn("MQTT: connection to {} lost: {}; messages are kept in {} until it is back",
               settings_.connection.broker.url(), why, journal_->dir());
}

void Publisher::on_published(int mid, int reason_code) {
  if (mid == status_mid_) status_acked_ = true;
  if (mid != inflight_mid_) return;
  inflight_mid_ = -1;
  if (reason_code >= 0x80) {  // the broker will not take it (its ACL): retrying would block the queue
    const std::optional<JournalEntry> e = journal_->front();
    log_->error("MQTT: {} refused the message on {}: {} (check the broker's ACL for this machine)",
                settings_.connection.broker.url(), e ? e->topic : "?", mqtt_reason_text(reason_code));
  }
  finish_front(reason_code < 0x80);
}

void Publisher::run() {
  const auto schedule_reconnect = [this](const std::string& why) {
    up_ = false;
    connected_ = false;
    set_state("disconnected", why);
    const double wait_s = backoff_.take_s();
    if (why != last_logged_error_ && stats().state != "refused") {
      last_logged_error_ = why;
      log_->warn("MQTT: {}: {}; trying again in {} s (then with back-off up to {} s); messages are kept in {}",
                 settings_.connection.broker.url(), why, wait_s, settings_.reconnect_max_s, journal_->dir());
    }
    reconnect_at_ns_ = mono_now_ns() + static_cast<std::int64_t>(wait_s * 1e9);
  };
  while (true) {
    {
      std::lock_guard lock(mutex_);
      if (stop_) break;
    }
    take_handed_over();
    if (up_) {
      if (connected_) send_next();
      const std::string error = connection_->loop(loop_timeout_ms);
      if (!error.empty()) schedule_reconnect(error);
      continue;
    }
    if (mono_now_ns() >= reconnect_at_ns_) {
      const std::string error = connection_->connect();
      if (error.empty()) {
        up_ = true;
        set_state("connecting", "");
      } else {
        schedule_reconnect(error);
      }
      continue;
    }
    std::unique_lock lock(mutex_);
    const auto wait_ns = std::min<std::int64_t>(reconnect_at_ns_ - mono_now_ns(), 200'000'000);
    wake_.wait_for(lock, std::chrono::nanoseconds(std::max<std::int64_t>(wait_ns, 0)),
                   [this] { return stop_ || !handed_over_.empty(); });
  }
  drain_before_exit();
}

void Publisher::drain_before_exit() {
  take_handed_over();
  const auto deadline = mono_now_ns() + static_cast<std::int64_t>(exit_drain_s * 1e9);
  while (connected_ && (journal_->size() > 0) && mono_now_ns() < deadline) {
    send_next();
    if (!connection_->loop(exit_loop_ms).empty()) break;
  }
  if (connected_) {
    status_acked_ = false;
    std::string error;
    status_mid_ = connection_->publish(topic_for(settings_.topic_prefix, settings_.machine, TopicLeaf::status),
                                       status_payload(false, "stopped"), 1, true, {}, error);
    const auto status_deadline = mono_now_ns() + 1'000'000'000;
    while (connected_ && !status_acked_ && mono_now_ns() < status_deadline) {
      if (!connection_->loop(exit_loop_ms).empty()) break;
    }
    stopping_ = true;
    connection_->disconnect();
    connection_->loop(exit_loop_ms);
  }
  if (journal_->size() > 0)
    log_->info("MQTT: {} message(s) not yet delivered stay in {} for the next start", journal_->size(),
               journal_->dir());
}

}  // namespace guideway::plant
