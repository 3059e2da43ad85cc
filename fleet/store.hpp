#pragma once
// The fleet's database: every machine's retained status, results (PARAMS, EXPLAIN) and events as the
// MQTT messages of the plant's topic tree bring them (plant/topics.hpp), in one SQLite file. WAL mode
// and a busy timeout let `guideway fleet status` read while `guideway fleet serve` writes. Not thread
// safe: one Store per thread.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fleet/payload_check.hpp"

struct sqlite3;

namespace guideway::fleet {

// The schema this code writes (PRAGMA user_version); a database of a newer one is refused, an older
// one is brought up to this one when `fleet serve` or `fleet ingest` opens it. 2: refusals, claimed times.
inline constexpr int schema_version = 2;

// $GUIDEWAY_FLEET_DB when set; else the service's database (system_database_path) when it exists; else
// $STATE_DIRECTORY/fleet.sqlite under systemd, $XDG_STATE_HOME/guideway/fleet.sqlite, or
// ~/.local/state/guideway/fleet.sqlite (core's default_state_dir()).
inline constexpr const char* system_database_path = "/var/lib/guideway-fleet/fleet.sqlite";
std::string default_database_path();

// What became of one message. `refused`: it breaks the documented shapes (fleet/payload_check.hpp) and
// is counted in the refusals, never stored; `ignored`: well formed but superseded (a status older than
// the one stored); `duplicate`: already stored (a retained copy, a redelivery).
struct IngestResult {
  enum Outcome { stored, duplicate, ignored, refused };
  Outcome outcome = refused;
  std::string reason;  // ignored, refused: why; stored: a note (a claimed time out of range), or ""
};

// One message as it arrived.
struct IngestInput {
  std::string_view topic;
  std::string_view payload;
  std::string_view produced_utc;  // its "produced_utc" property, "" when absent
  std::string_view received_utc;  // when it arrived (this host's clock)
};

// A produced time is believed within [2000-01-01, received + claimed_time_slack_s]: beyond, the receive
// time orders the result and the claimed time is kept beside it (`claimed_utc`), so that a daemon whose
// clock is wrong can neither bury its result in the past nor freeze a machine's latest in the future.
inline constexpr const char* earliest_believed_utc = "2000-01-01T00:00:00.000Z";
inline constexpr double claimed_time_slack_s = 86400.0;

struct RefusalRow {
  std::string machine;  // "" when the topic names none
  std::string topic;
  std::string reason;
  std::string received_utc;
  std::int64_t size_bytes = 0;
};
std::string_view to_string(IngestResult::Outcome outcome) noexcept;

struct MachineRow {
  std::string machine;
  std::string state;  // "online", "offline", or "" (only devices or results seen so far)
  std::string since;  // UTC; the status's own, or the receive time of a will without one
  std::string release;
  std::string reason;         // offline: "connection lost", "stopped", ...
  std::string last_seen_utc;  // the newest message of any kind from it
};

struct ResultRow {
  std::int64_t id = 0;
  std::string machine;
  std::string kind;           // "dbb", "runout", ...
  std::string message_class;  // "PARAMS" or "EXPLAIN"
  std::string produced_utc;   // when the daemon made it (ISO 8601 UTC, ms); the receive time when unknown
  std::string received_utc;
  std::string session;
  std::string payload;      // the JSON object as published
  std::string claimed_utc;  // a produced time that was not believed ("" when it was, or none was given)
};

struct EventRow {
  std::string machine;
  std::string produced_utc;
  std::string received_utc;
  std::string payload;
};

class Store {
 public:
  enum class Open { create, existing };
  // `create`: the file and its parent directory (0700) are made when missing. `existing`: opened read
  // only (status, history, report: read access to the files is enough, as for the service's group); a
  // missing file is an error ("no fleet database at PATH: start `guideway fleet serve` first"). Throws
  // std::runtime_error naming the path (newer schema, not a database, ...).
  explicit Store(const std::string& path, Open mode = Open::create);
  ~Store();
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  // One MQTT message of the tree under `topic_prefix`. `produced_utc`: the message's "produced_utc"
  // property ("" when absent: the receive time is used); `received_utc`: when it arrived. A message
  // already stored (same machine, topic and payload: a retained copy on resubscription, a QoS 1
  // redelivery) is a duplicate and adds nothing. Throws std::runtime_error when the database cannot
  // take it (full disk, locked past the busy timeout): nothing of it is then stored.
  IngestResult ingest(std::string_view topic_prefix, std::string_view topic, std::string_view payload,
                      std::string_view produced_utc, std::string_view received_utc);
  // Several messages in one transaction: all committed when it returns (one result each, in order), none
  // when it throws. What `fleet serve` acknowledges to the broker only after it returns.
  std::vector<IngestResult> ingest_batch(std::string_view topic_prefix, const std::vector<IngestInput>& messages);

  // Payloads over this are refused (default_max_payload_bytes).
  void set_max_payload_bytes(std::size_t bytes) noexcept { max_payload_bytes_ = bytes; }
  // How long a write waits for another connection's lock before it fails (default 5 s).
  void set_busy_timeout_ms(int ms);

  [[nodiscard]] std::vector<MachineRow> machines() const;  // by name
  // A machine's results, oldest produced first; empty kind or class: all.
  [[nodiscard]] std::vector<ResultRow> results(std::string_view machine, std::string_view kind = {},
                                               std::string_view message_class = {}) const;
  // The newest `per_kind` results of each machine, class and kind, oldest first within each.
  [[nodiscard]] std::vector<ResultRow> latest_results(int per_kind) const;
  [[nodiscard]] std::vector<EventRow> events(std::string_view machine) const;  // oldest first
  // Messages refused at ingest: how many ever, and the newest (at most refusals_kept, newest last).
  [[nodiscard]] std::int64_t refused_count() const;
  [[nodiscard]] std::vector<RefusalRow> refusals(std::size_t newest) const;
  static constexpr std::size_t refusals_kept = 100;

  [[nodiscard]] const std::string& path() const noexcept { return path_; }

 private:
  IngestResult ingest_one(std::string_view topic_prefix, const IngestInput& message);
  IngestResult refuse(std::string_view machine, const IngestInput& message, std::string reason);

  std::string path_;
  sqlite3* db_ = nullptr;
  std::size_t max_payload_bytes_;
};

}  // namespace guideway::fleet
