// The fleet's SQLite database (store.hpp): machines' status, results and events as the broker delivered them.
#include "fleet/store.hpp"

#include <sqlite3.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "core/runtime_paths.hpp"
#include "core/utc_time.hpp"
#include "plant/topics.hpp"
#include "results/message_class.hpp"

namespace guideway::fleet {

namespace {

constexpr const char* schema_sql = R"sql(
CREATE TABLE machines(
  machine TEXT PRIMARY KEY,
  state TEXT NOT NULL DEFAULT '',
  since TEXT NOT NULL DEFAULT '',
  release TEXT NOT NULL DEFAULT '',
  reason TEXT NOT NULL DEFAULT '',
  status_payload TEXT NOT NULL DEFAULT '', -- the status applied: its retained copy is a duplicate
  status_clock TEXT NOT NULL DEFAULT '',   -- the newest time a status carried (the daemon's clock)
  last_seen_utc TEXT NOT NULL DEFAULT '');
CREATE TABLE results(
  id INTEGER PRIMARY KEY,
  machine TEXT NOT NULL,
  kind TEXT NOT NULL,
  class TEXT NOT NULL,
  produced_utc TEXT NOT NULL,
  received_utc TEXT NOT NULL,
  session TEXT NOT NULL,
  payload TEXT NOT NULL,
  digest INTEGER NOT NULL);
CREATE INDEX results_by_digest ON results(machine, class, kind, digest);
CREATE INDEX results_by_time ON results(machine, class, kind, produced_utc);
CREATE TABLE events(
  id INTEGER PRIMARY KEY,
  machine TEXT NOT NULL,
  produced_utc TEXT NOT NULL,
  received_utc TEXT NOT NULL,
  payload TEXT NOT NULL,
  digest INTEGER NOT NULL);
CREATE INDEX events_by_digest ON events(machine, digest);
CREATE INDEX events_by_time ON events(machine, produced_utc);
)sql";

// Version 2: messages refused at ingest (the newest kept, all counted), and the produced times that
// were not believed. A new database is made as version 1 and brought up the same way as an old one,
// whose unbelievable times are moved aside.
constexpr const char* migrate_1_to_2_sql = R"sql(
CREATE TABLE refusals(
  id INTEGER PRIMARY KEY,
  machine TEXT NOT NULL,
  topic TEXT NOT NULL,
  reason TEXT NOT NULL,
  received_utc TEXT NOT NULL,
  size INTEGER NOT NULL);
CREATE TABLE counters(name TEXT PRIMARY KEY, value INTEGER NOT NULL);
ALTER TABLE results ADD COLUMN claimed_utc TEXT NOT NULL DEFAULT '';
ALTER TABLE events ADD COLUMN claimed_utc TEXT NOT NULL DEFAULT '';
UPDATE results SET claimed_utc = produced_utc, produced_utc = received_utc
  WHERE length(produced_utc) != 24 OR produced_utc < '2000'
     OR produced_utc > strftime('%Y-%m-%dT%H:%M:%fZ', received_utc, '+1 day');
UPDATE events SET claimed_utc = produced_utc, produced_utc = received_utc
  WHERE length(produced_utc) != 24 OR produced_utc < '2000'
     OR produced_utc > strftime('%Y-%m-%dT%H:%M:%fZ', received_utc, '+1 day');
UPDATE machines SET since = last_seen_utc, status_clock = ''
  WHERE (since != '' AND (length(since) != 24 OR since < '2000'
                          OR since > strftime('%Y-%m-%dT%H:%M:%fZ', last_seen_utc, '+1 day')))
     OR (status_clock != '' AND (length(status_clock) != 24 OR status_clock < '2000'
                                 OR status_clock > strftime('%Y-%m-%dT%H:%M:%fZ', last_seen_utc, '+1 day')));
)sql";

// FNV-1a: narrows the duplicate search to a few rows; the payloads themselves are compared.
std::int64_t digest_of(std::string_view text) {
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return static_cast<std::int64_t>(h);
}

// One prepared statement; text parameters are bound by position (1-based) and copied.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &s_, nullptr) != SQLITE_OK) fail("prepare");
  }
  ~Statement() { sqlite3_finalize(s_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  Statement& bind(int i, std::string_view text) {
    // An empty view may have no data pointer, which SQLite would bind as NULL rather than ''.
    sqlite3_bind_text(s_, i, text.empty() ? "" : text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
    return *this;
  }
  Statement& bind(int i, std::int64_t v) {
    sqlite3_bind_int64(s_, i, v);
    return *this;
  }
  bool step() {  // true: a row is ready
    const int rc = sqlite3_step(s_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    fail("step");
  }
  [[nodiscard]] std::string text(int col) const {
    const auto* p = reinterpret_cast<const char*>(sqlite3_column_text(s_, col));
    return p ? std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(s_, col))) : std::string();
  }
  [[nodiscard]] std::int64_t integer(int col) const { return sqlite3_column_int64(s_, col); }

 private:
  [[noreturn]] void fail(const char* what) const {
    throw std::runtime_error(std::string("fleet database: ") + what + ": " + sqlite3_errmsg(db_));
  }
  sqlite3* db_;
  sqlite3_stmt* s_ = nullptr;
};

void exec(sqlite3* db, const char* sql) {
  char* err = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : sqlite3_errmsg(db);
    sqlite3_free(err);
    throw std::runtime_error(msg);
  }
}

// BEGIN IMMEDIATE .. COMMIT, rolled back when the scope is left by an exception.
class Transaction {
 public:
  explicit Transaction(sqlite3* db) : db_(db) { exec(db_, "BEGIN IMMEDIATE"); }
  ~Transaction() {
    if (db_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  }
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  void commit() {
    exec(db_, "COMMIT");
    db_ = nullptr;
  }

 private:
  sqlite3* db_;
};

// The parent directories that are missing, made 0700: the database holds the plant's results.
void make_private_parents(const std::string& path) {
  const auto parent = std::filesystem::path(path).parent_path();
  if (parent.empty()) return;
  std::filesystem::path p;
  for (const auto& part : parent) {
    p /= part;
    if (::mkdir(p.c_str(), 0700) != 0 && errno != EEXIST)
      throw std::runtime_error("cannot create directory " + p.string() +
                               " for the fleet database: " + std::strerror(errno));
  }
}

// A time given by a message or the caller, normalised so that text order is time order.
std::optional<std::string> normalised_time(std::string_view text) {
  const auto s = parse_utc_iso(text);
  if (!s) return std::nullopt;
  return utc_iso_ms(*s);
}

// A time a message claims, normalised, when it is believable against the receive time
// (earliest_believed_utc .. received + claimed_time_slack_s); nullopt otherwise.
std::optional<std::string> believed_time(std::string_view claimed, double received_s) {
  const auto t = parse_utc_iso(claimed);
  static const double earliest_s = *parse_utc_iso(earliest_believed_utc);
  if (!t || *t < earliest_s || *t > received_s + claimed_time_slack_s) return std::nullopt;
  return utc_iso_ms(*t);
}

// What is kept of a claimed time that was not believed: bounded, for people to look at.
std::string claimed_text(std::string_view claimed) { return std::string(claimed.substr(0, 64)); }

IngestResult ignored(std::string reason) { return {IngestResult::ignored, std::move(reason)}; }

std::string string_field(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
}

std::int64_t user_version(sqlite3* db) {
  Statement v(db, "PRAGMA user_version");
  v.step();
  return v.integer(0);
}

}  // namespace

std::string default_database_path() {
  if (const char* env = std::getenv("GUIDEWAY_FLEET_DB"); env != nullptr && *env != '\0') return env;
  // The service's database (guideway-fleet.service, StateDirectory=guideway-fleet), when there is one and
  // this is not the service itself: the plant server's users read it without --db.
  if (std::getenv("STATE_DIRECTORY") == nullptr) {
    std::error_code ec;
    if (std::filesystem::exists(system_database_path, ec)) return system_database_path;
  }
  return default_state_dir() + "/fleet.sqlite";
}

std::string_view to_string(IngestResult::Outcome outcome) noexcept {
  switch (outcome) {
    case IngestResult::stored:
      return "stored";
    case IngestResult::duplicate:
      return "duplicate";
    case IngestResult::ignored:
      return "ignored";
    case IngestResult::refused:
      break;
  }
  return "refused";
}

Store::Store(const std::string& path, Open mode) : path_(path), max_payload_bytes_(default_max_payload_bytes) {
  const auto where = [&](const std::string& what) {
    return std::runtime_error("fleet database " + path + ": " + what);
  };
  const bool read_only = mode == Open::existing;
  int flags = (read_only ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE) | SQLITE_OPEN_NOMUTEX;
  if (read_only) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec))
      throw std::runtime_error("no fleet database at " + path + ": start `guideway fleet serve` first");
  } else {
    make_private_parents(path);
    flags |= SQLITE_OPEN_CREATE;
  }
  if (sqlite3_open_v2(path.c_str(), &db_, flags, nullptr) != SQLITE_OK) {
    const std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw where(msg);
  }
  try {
    sqlite3_busy_timeout(db_, 5000);  // a reader and the writer wait for each other's short transactions
    // Whose file it is is settled before anything is written: a database of a newer guideway, or of
    // someone else, is refused unaltered (not even switched to WAL).
    const auto version = user_version(db_);
    if (version > schema_version)
      throw where("its schema is version " + std::to_string(version) + ", newer than this guideway knows (" +
                  std::to_string(schema_version) + "): use the guideway release that wrote it, or a newer one");
    if (version == 0) {
      Statement tables(db_, "SELECT count(*) FROM sqlite_master");
      tables.step();
      if (tables.integer(0) != 0) throw where("not a fleet database (it has tables of its own and no schema version)");
      if (read_only) throw where("not a fleet database (no schema version): was it made by `guideway fleet serve`?");
    }
    if (!read_only) {
      exec(db_, "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL");
      // The -wal and -shm files stay when the writer closes: a reader that may not create files in the
      // directory (the service's group, docs/plant.md) can open a WAL database only while they exist.
      int persist = 1;
      sqlite3_file_control(db_, "main", SQLITE_FCNTL_PERSIST_WAL, &persist);
      // Looked at again inside the write transaction: another process (fleet serve, fleet ingest) may
      // have made or upgraded the schema meanwhile.
      Transaction t(db_);
      const auto now = user_version(db_);
      if (now == 0) {
        Statement tables(db_, "SELECT count(*) FROM sqlite_master");
        tables.step();
        if (tables.integer(0) != 0)
          throw where("not a fleet database (it has tables of its own and no schema version)");
        exec(db_, schema_sql);
      }
      if (now < 2) exec(db_, migrate_1_to_2_sql);
      if (now < schema_version) exec(db_, ("PRAGMA user_version=" + std::to_string(schema_version)).c_str());
      t.commit();
    }
  } catch (const std::runtime_error& e) {
    sqlite3_close(db_);
    db_ = nullptr;
    const std::string msg = e.what();
    if (msg.starts_with("fleet database " + path)) throw;
    throw where(msg);
  }
}

Store::~Store() { sqlite3_close(db_); }

void Store::set_busy_timeout_ms(int ms) { sqlite3_busy_timeout(db_, ms); }

IngestResult Store::ingest(std::string_view topic_prefix, std::string_view topic, std::string_view payload,
                           std::string_view produced_utc, std::string_view received_utc) {
  return ingest_batch(topic_prefix, {IngestInput{topic, payload, produced_utc, received_utc}}).front();
}

std::vector<IngestResult> Store::ingest_batch(std::string_view topic_prefix, const std::vector<IngestInput>& messages) {
  Transaction tx(db_);
  std::vector<IngestResult> out;
  out.reserve(messages.size());
  for (const auto& m : messages) {
    // Each message's changes are its own: a refused or ignored one leaves no trace but its refusal.
    exec(db_, "SAVEPOINT message");
    IngestResult r = ingest_one(topic_prefix, m);
    if (r.outcome == IngestResult::refused || r.outcome == IngestResult::ignored) {
      exec(db_, "ROLLBACK TO message");
      if (r.outcome == IngestResult::refused) {
        const auto t = plant::parse_topic(topic_prefix, m.topic);
        refuse(t ? std::string_view(t->machine) : std::string_view(), m, r.reason);
      }
    }
    exec(db_, "RELEASE message");
    out.push_back(std::move(r));
  }
  tx.commit();
  return out;
}

IngestResult Store::refuse(std::string_view machine, const IngestInput& m, std::string reason) {
  Statement ins(db_, "INSERT INTO refusals(machine, topic, reason, received_utc, size) VALUES(?1, ?2, ?3, ?4, ?5)");
  ins.bind(1, machine.substr(0, 256)).bind(2, m.topic.substr(0, 512)).bind(3, std::string_view(reason).substr(0, 512));
  ins.bind(4, normalised_time(m.received_utc).value_or(utc_now_iso_ms()))
      .bind(5, static_cast<std::int64_t>(m.payload.size()))
      .step();
  Statement trim(db_, "DELETE FROM refusals WHERE id <= (SELECT max(id) FROM refusals) - ?1");
  trim.bind(1, static_cast<std::int64_t>(refusals_kept)).step();
  Statement count(db_,
                  "INSERT INTO counters(name, value) VALUES('refused', 1) "
                  "ON CONFLICT(name) DO UPDATE SET value = value + 1");
  count.step();
  return {IngestResult::refused, std::move(reason)};
}

IngestResult Store::ingest_one(std::string_view topic_prefix, const IngestInput& m) {
  const auto refused = [](std::string why) { return IngestResult{IngestResult::refused, std::move(why)}; };
  const auto t = plant::parse_topic(topic_prefix, m.topic);
  if (!t) return refused("not our topic tree (" + std::string(topic_prefix) + "/MACHINE/...)");
  const auto received_s = parse_utc_iso(m.received_utc);
  if (!received_s) return refused("receive time '" + claimed_text(m.received_utc) + "' is not ISO 8601 UTC");
  const std::string received = utc_iso_ms(*received_s);
  if (std::string p = payload_size_problem(m.payload, max_payload_bytes_); !p.empty()) return refused(p);
  nlohmann::json j = nlohmann::json::parse(m.payload, nullptr, false);
  if (j.is_discarded()) return refused("the payload is not JSON");
  if (std::string p = payload_problem(t->leaf, t->kind, j); !p.empty()) return refused(p);
  const std::string named = string_field(j, "machine");
  if (!named.empty() && named != t->machine)
    return refused("the payload names machine '" + claimed_text(named) + "', the topic '" + t->machine + "'");

  Statement seen(db_,
                 "INSERT INTO machines(machine, last_seen_utc) VALUES(?1, ?2) ON CONFLICT(machine) DO UPDATE SET "
                 "last_seen_utc = max(last_seen_utc, excluded.last_seen_utc)");
  seen.bind(1, t->machine).bind(2, received).step();
  if (t->leaf == plant::TopicLeaf::devices) return {IngestResult::stored, {}};  // only the last-seen time

  // A producer's clock that cannot be read or believed is no reason to lose a result: the receive time
  // orders it, and the claimed time is kept beside it.
  const auto believed = believed_time(m.produced_utc, *received_s);
  const std::string produced = believed.value_or(received);
  const std::string claimed = believed || m.produced_utc.empty() ? std::string() : claimed_text(m.produced_utc);
  IngestResult out{IngestResult::stored, {}};
  if (!claimed.empty()) out.reason = "produced time '" + claimed + "' not believed: the receive time orders it";
  const std::string text(m.payload);
  switch (t->leaf) {
    case plant::TopicLeaf::status: {
      const std::string state = string_field(j, "state");
      const std::string since_claimed = string_field(j, "since");
      const auto since = believed_time(since_claimed, *received_s);
      if (!since && !since_claimed.empty())
        out.reason = "status since '" + claimed_text(since_claimed) + "' not believed: the receive time stands in";
      // A will (no time: the broker publishes it when the connection is lost, after whatever that
      // connection brought) always applies, counting from when it arrived. A status with a time of its own
      // applies unless that time is older than the newest one seen before (a late delivery): both on the
      // daemon's clock, so a skew between the daemon's and this host's clock never hides a will or the
      // status after it. Only believed times enter that comparison.
      Statement cur(db_, "SELECT status_payload, status_clock FROM machines WHERE machine = ?1");
      cur.bind(1, t->machine).step();
      if (cur.text(0) == text) return {IngestResult::duplicate, {}};
      if (since && *since < cur.text(1)) return ignored("status older than the one stored (" + cur.text(1) + ")");
      Statement up(db_,
                   "UPDATE machines SET state = ?2, since = ?3, release = ?4, reason = ?5, status_payload = ?6, "
                   "status_clock = max(status_clock, ?7) WHERE machine = ?1");
      up.bind(1, t->machine).bind(2, state).bind(3, since.value_or(received)).bind(4, string_field(j, "release"));
      up.bind(5, string_field(j, "reason")).bind(6, text).bind(7, since.value_or("")).step();
      return out;
    }
    case plant::TopicLeaf::params:
    case plant::TopicLeaf::explain: {
      const std::string cls(results::to_string(t->leaf == plant::TopicLeaf::params ? results::MessageClass::params
                                                                                   : results::MessageClass::explain));
      const std::string declared = string_field(j, "class");
      if (!declared.empty() && declared != cls)
        return refused("the payload is a " + claimed_text(declared) + " on a " +
                       std::string(plant::to_string(t->leaf)) + " topic");
      const auto digest = digest_of(text);
      Statement dup(
          db_,
          "SELECT 1 FROM results WHERE machine = ?1 AND class = ?2 AND kind = ?3 AND digest = ?4 AND payload = ?5");
      if (dup.bind(1, t->machine).bind(2, cls).bind(3, t->kind).bind(4, digest).bind(5, text).step())
        return {IngestResult::duplicate, {}};
      Statement ins(db_,
                    "INSERT INTO results(machine, kind, class, produced_utc, received_utc, session, payload, digest, "
                    "claimed_utc) VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)");
      ins.bind(1, t->machine).bind(2, t->kind).bind(3, cls).bind(4, produced).bind(5, received);
      ins.bind(6, string_field(j, "session")).bind(7, text).bind(8, digest).bind(9, claimed).step();
      return out;
    }
    case plant::TopicLeaf::event: {
      const auto digest = digest_of(text);
      Statement dup(db_, "SELECT 1 FROM events WHERE machine = ?1 AND digest = ?2 AND payload = ?3");
      if (dup.bind(1, t->machine).bind(2, digest).bind(3, text).step()) return {IngestResult::duplicate, {}};
      Statement ins(db_,
                    "INSERT INTO events(machine, produced_utc, received_utc, payload, digest, claimed_utc) "
                    "VALUES(?1, ?2, ?3, ?4, ?5, ?6)");
      ins.bind(1, t->machine).bind(2, produced).bind(3, received).bind(4, text).bind(5, digest).bind(6, claimed).step();
      return out;
    }
    case plant::TopicLeaf::devices:
      break;  // handled above
  }
  return out;
}

std::int64_t Store::refused_count() const {
  Statement s(db_, "SELECT coalesce((SELECT value FROM counters WHERE name = 'refused'), 0)");
  s.step();
  return s.integer(0);
}

std::vector<RefusalRow> Store::refusals(std::size_t newest) const {
  Statement s(db_,
              "SELECT machine, topic, reason, received_utc, size FROM (SELECT * FROM refusals ORDER BY id DESC "
              "LIMIT ?1) ORDER BY id");
  s.bind(1, static_cast<std::int64_t>(newest));
  std::vector<RefusalRow> out;
  while (s.step()) out.push_back({s.text(0), s.text(1), s.text(2), s.text(3), s.integer(4)});
  return out;
}

std::vector<MachineRow> Store::machines() const {
  Statement s(db_, "SELECT machine, state, since, release, reason, last_seen_utc FROM machines ORDER BY machine");
  std::vector<MachineRow> out;
  while (s.step()) out.push_back({s.text(0), s.text(1), s.text(2), s.text(3), s.text(4), s.text(5)});
  return out;
}

namespace {
constexpr const char* result_columns =
    "id, machine, kind, class, produced_utc, received_utc, session, payload, claimed_utc";
ResultRow result_row(const Statement& s) {
  return {s.integer(0), s.text(1), s.text(2), s.text(3), s.text(4), s.text(5), s.text(6), s.text(7), s.text(8)};
}
}  // namespace

std::vector<ResultRow> Store::results(std::string_view machine, std::string_view kind,
                                      std::string_view message_class) const {
  Statement s(db_, (std::string("SELECT ") + result_columns +
                    " FROM results WHERE machine = ?1 AND (?2 = '' OR kind = ?2) AND (?3 = '' OR class = ?3) "
                    "ORDER BY produced_utc, id")
                       .c_str());
  s.bind(1, machine).bind(2, kind).bind(3, message_class);
  std::vector<ResultRow> out;
  while (s.step()) out.push_back(result_row(s));
  return out;
}

std::vector<ResultRow> Store::latest_results(int per_kind) const {
  Statement s(db_, (std::string("SELECT ") + result_columns +
                    " FROM (SELECT *, row_number() OVER (PARTITION BY machine, class, kind ORDER BY produced_utc "
                    "DESC, id DESC) AS n FROM results) WHERE n <= ?1 ORDER BY machine, class, kind, produced_utc, id")
                       .c_str());
  s.bind(1, std::int64_t{per_kind});
  std::vector<ResultRow> out;
  while (s.step()) out.push_back(result_row(s));
  return out;
}

std::vector<EventRow> Store::events(std::string_view machine) const {
  Statement s(
      db_,
      "SELECT machine, produced_utc, received_utc, payload FROM events WHERE machine = ?1 ORDER BY produced_utc, id");
  s.bind(1, machine);
  std::vector<EventRow> out;
  while (s.step()) out.push_back({s.text(0), s.text(1), s.text(2), s.text(3)});
  return out;
}

}  // namespace guideway::fleet
