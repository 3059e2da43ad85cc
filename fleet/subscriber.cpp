// `guideway fleet serve` (subscriber.hpp): every machine's topics from the broker into the store.
#include "fleet/subscriber.hpp"

#include <chrono>
#include <thread>

#include "core/backoff.hpp"
#include "core/mono_clock.hpp"
#include "core/printable.hpp"
#include "core/utc_time.hpp"
#include "plant/mqtt_inbox.hpp"
#include "plant/topics.hpp"

namespace guideway::fleet {

namespace {

constexpr std::int64_t minute_ns = 60'000'000'000LL;
constexpr int refusals_logged_per_minute = 10;

}  // namespace

Subscriber::Subscriber(SubscriberSettings settings, Store& store, Log log)
    : settings_(std::move(settings)), store_(store), log_(std::move(log)) {
  store_.set_max_payload_bytes(settings_.max_payload_bytes);
}

void Subscriber::run(const std::atomic<bool>& stop) {
  plant::InboxSettings in;
  in.connection = settings_.connection;
  in.filter = plant::subscription_filter(settings_.topic_prefix);
  in.receive_maximum = settings_.batch_max;
  // The payload and what MQTT wraps it in (topic, properties): a larger message is never sent to us.
  in.max_message_bytes = static_cast<std::uint32_t>(settings_.max_payload_bytes + 70000);
  plant::MqttInbox inbox(in, log_);

  int refusals_logged = 0;
  std::uint64_t refusals_unlogged = 0;
  auto minute_ends_ns = mono_now_ns() + minute_ns;
  SubscriberCounts reported;
  const auto each_minute = [&] {  // a line a minute, when something came
    if (mono_now_ns() < minute_ends_ns) return;
    minute_ends_ns = mono_now_ns() + minute_ns;
    if (refusals_unlogged > 0) log_("... and " + std::to_string(refusals_unlogged) + " more refused (fleet status)");
    refusals_logged = 0;
    refusals_unlogged = 0;
    if (counts_.stored != reported.stored || counts_.duplicates != reported.duplicates ||
        counts_.refused != reported.refused) {
      log_("stored " + std::to_string(counts_.stored) + " message(s) so far (" + std::to_string(counts_.duplicates) +
           " already stored, " + std::to_string(counts_.ignored) + " superseded, " + std::to_string(counts_.refused) +
           " refused)");
      reported = counts_;
    }
  };
  const auto store = [&](const std::vector<plant::InboxMessage>& batch) {
    each_minute();
    const std::string received = utc_now_iso_ms();
    std::vector<IngestInput> inputs;
    inputs.reserve(batch.size());
    for (const auto& m : batch) inputs.push_back({m.topic, m.payload, m.produced_utc, received});
    const auto results = store_.ingest_batch(settings_.topic_prefix, inputs);  // throws: nothing acknowledged
    for (std::size_t i = 0; i < results.size(); ++i) {
      const auto& r = results[i];
      switch (r.outcome) {
        case IngestResult::stored:
          ++counts_.stored;
          break;
        case IngestResult::duplicate:
          ++counts_.duplicates;
          break;
        case IngestResult::ignored:
          ++counts_.ignored;
          break;
        case IngestResult::refused:
          ++counts_.refused;
          if (refusals_logged < refusals_logged_per_minute) {
            ++refusals_logged;
            log_("refused a message on " + printable(batch[i].topic) + " (" + std::to_string(batch[i].payload.size()) +
                 " bytes): " + printable(r.reason));
          } else {
            ++refusals_unlogged;
          }
          break;
      }
      if (r.outcome == IngestResult::stored && !r.reason.empty())
        log_(printable(batch[i].topic) + ": " + printable(r.reason));
    }
  };

  Backoff backoff{1.0, settings_.reconnect_max_s};
  std::string last_error;
  while (!stop.load()) {
    const std::string why = inbox.run_connection(stop, store);
    counts_.store_failures = inbox.counts().store_failures;
    if (stop.load()) break;
    if (inbox.accepted()) backoff.reset();
    if (why != last_error || inbox.accepted()) {
      log_(settings_.connection.broker.url() + ": " + printable(why) + "; trying again with back-off up to " +
           std::to_string(static_cast<int>(settings_.reconnect_max_s)) + " s");
      last_error = why;
    }
    const auto until = mono_now_ns() + backoff.take_ns();
    while (!stop.load() && mono_now_ns() < until) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

}  // namespace guideway::fleet
