#include "fleet/subscriber.hpp"

#include <chrono>
#include <thread>

#include "core/backoff.hpp"
#include "core/mono_clock.hpp"
#include "core/utc_time.hpp"
#include "plant/topics.hpp"

namespace guideway::fleet {

Subscriber::Subscriber(SubscriberSettings settings, Store& store, Log log)
    : settings_(std::move(settings)), store_(store), log_(std::move(log)) {}

void Subscriber::on_message(std::string_view topic, std::string_view payload, std::string_view produced_utc) {
  const std::string received = utc_now_iso_ms();
  try {
    const IngestResult r = store_.ingest(settings_.topic_prefix, topic, payload, produced_utc, received);
    switch (r.outcome) {
      case IngestResult::stored: ++counts_.stored; break;
      case IngestResult::duplicate: ++counts_.duplicates; break;
      case IngestResult::ignored:
        ++counts_.ignored;
        log_("ignored a message on " + std::string(topic) + ": " + r.reason);
        break;
    }
  } catch (const std::exception& e) {  // the database: said, and the next message tried again
    ++counts_.ignored;
    log_("could not store the message on " + std::string(topic) + ": " + e.what());
  }
}

void Subscriber::run(const std::atomic<bool>& stop) {
  const std::string filter = plant::subscription_filter(settings_.topic_prefix);
  plant::MqttConnection connection(
      settings_.connection,
      plant::MqttConnection::Callbacks{
          .connected =
              [&](int rc, const std::string& why) {
                if (rc != 0) {
                  log_("the broker refused the connection: " + why);
                  return;
                }
                connected_ = true;
                subscribe_ = true;  // from run(): libmosquitto holds its callback lock here
              },
          .disconnected = [&](const std::string& why) {
            if (connected_) log_("connection lost: " + why);
            connected_ = false;
          },
          .published = nullptr,
          .message = [&](std::string_view topic, std::string_view payload,
                         std::string_view produced) { on_message(topic, payload, produced); }});
  Backoff backoff{1.0, settings_.reconnect_max_s};
  std::string last_error;
  SubscriberCounts reported;
  auto next_report_ns = mono_now_ns() + 60'000'000'000LL;
  while (!stop.load()) {
    std::string error = connection.connect();
    while (error.empty() && !stop.load()) {
      error = connection.loop(100);
      if (connected_) backoff.reset();
      if (subscribe_) {
        subscribe_ = false;
        std::string why;
        if (!connection.subscribe(filter, 1, why)) log_("cannot subscribe to " + filter + ": " + why);
        log_("connected to " + settings_.connection.broker.url() + " as " + settings_.connection.client_id +
             "; subscribed to " + filter);
      }
      if (mono_now_ns() >= next_report_ns) {  // a line a minute, when something came
        next_report_ns = mono_now_ns() + 60'000'000'000LL;
        if (counts_.stored != reported.stored || counts_.duplicates != reported.duplicates) {
          log_("stored " + std::to_string(counts_.stored) + " message(s) so far (" + std::to_string(counts_.duplicates) +
               " already stored, " + std::to_string(counts_.ignored) + " ignored)");
          reported = counts_;
        }
      }
    }
    if (stop.load()) break;
    connected_ = false;
    if (error != last_error) {
      log_(settings_.connection.broker.url() + ": " + error + "; trying again with back-off up to " +
           std::to_string(static_cast<int>(settings_.reconnect_max_s)) + " s");
      last_error = error;
    }
    const auto until = mono_now_ns() + static_cast<std::int64_t>(backoff.take() * 1e9);
    while (!stop.load() && mono_now_ns() < until) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  connection.disconnect();
  connection.loop(100);
}

}  // namespace guideway::fleet
