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

struct sqlite3;

namespace guideway::fleet {

// The schema this code writes (PRAGMA user_version); a database of a newer one is refused.
inline constexpr int schema_version = 1;

// $GUIDEWAY_FLEET_DB when set; else the service's database (system_database_path) when it exists; else
// $STATE_DIRECTORY/fleet.sqlite under systemd, $XDG_STATE_HOME/guideway/fleet.sqlite, or
// ~/.local/state/guideway/fleet.sqlite (core's default_state_dir()).
inline constexpr const char* system_database_path = "/var/lib/guideway-fleet/fleet.sqlite";
std::string default_database_path();

struct IngestResult {
  enum Outcome { stored, duplicate, ignored };
  Outcome outcome = ignored;
  std::string reason;  // ignored: why (not our tree, not JSON, ...)
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
  std::string payload;  // the JSON object as published
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
  // redelivery) is a duplicate and adds nothing.
  IngestResult ingest(std::string_view topic_prefix, std::string_view topic, std::string_view payload,
                      std::string_view produced_utc, std::string_view received_utc);

  [[nodiscard]] std::vector<MachineRow> machines() const;  // by name
  // A machine's results, oldest produced first; empty kind or class: all.
  [[nodiscard]] std::vector<ResultRow> results(std::string_view machine, std::string_view kind = {},
                                               std::string_view message_class = {}) const;
  // The newest `per_kind` results of each machine, class and kind, oldest first within each.
  [[nodiscard]] std::vector<ResultRow> latest_results(int per_kind) const;
  [[nodiscard]] std::vector<EventRow> events(std::string_view machine) const;  // oldest first

  [[nodiscard]] const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
};

}  // namespace guideway::fleet
