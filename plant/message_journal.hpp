#pragma once
// The publisher's queue of QoS 1 messages not yet acknowledged by the broker, on disk (one file per
// message in a directory of the state directory) so that a broker outage and a restart of the daemon
// lose nothing. Bounded in messages and bytes; past a bound a message is dropped and counted, in the
// order of eviction of docs/plant.md: the oldest event first, then the oldest state transition, the
// oldest result last (events also have a share of their own). Not thread safe (the publisher's thread
// owns it).

#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>

namespace guideway::plant {

// What a message is to the journal, in the order of eviction (first evicted first). A message is only
// ever dropped for one of its own share or of a share evicted before it: results never make room for
// state transitions or events, state transitions never for events.
enum class JournalShare : std::uint8_t {
  events,       // what happened inside a device (an EMCY, a node's reboot): rate-limited, a bounded share
  transitions,  // a device or an emulator changed state
  results,      // PARAMS, EXPLAIN and a session's EVENTs: what the journal exists for
};
inline constexpr std::size_t journal_share_count = 3;
std::string_view to_string(JournalShare share) noexcept;  // "events", "transitions", "results"

struct JournalEntry {
  std::string topic;
  std::string payload;
  std::string produced_utc;  // when the daemon made it (ISO 8601 UTC, ms)
  bool retain = false;
  JournalShare share = JournalShare::results;
};

struct JournalBounds {
  std::size_t max_messages = 10000;
  std::size_t max_bytes = 64u << 20;
  // The events' share: at most so many of the messages and of the bytes are events.
  std::size_t max_event_messages = 2500;
  std::size_t max_event_bytes = 16u << 20;
};

// Messages dropped to keep within the bounds, by share.
using JournalDrops = std::array<std::uint64_t, journal_share_count>;

class MessageJournal {
 public:
  // Creates `dir` (0700) when missing and takes up the messages a previous run left there, oldest
  // first. Throws std::runtime_error naming the directory when it cannot be used.
  MessageJournal(std::string dir, JournalBounds bounds);

  // Appends `entry` (written to disk before this returns); returns the messages dropped, by share, to
  // stay within the bounds (`entry` itself when it is an event with no room left for it). Throws
  // std::runtime_error when the file cannot be written (disk full).
  JournalDrops push(const JournalEntry& entry);
  // The oldest message (read from its file), or nullopt when empty. A file that cannot be read back
  // (truncated by a crash, edited) is removed and counted in unreadable().
  std::optional<JournalEntry> front();
  void pop_front();

  [[nodiscard]] std::size_t size() const;
  [[nodiscard]] std::size_t size(JournalShare share) const { return files_[index(share)].size(); }
  [[nodiscard]] std::size_t bytes() const;
  [[nodiscard]] std::size_t taken_up() const { return taken_up_; }  // messages found at start
  [[nodiscard]] std::uint64_t unreadable() const { return unreadable_; }
  [[nodiscard]] std::uint64_t dropped(JournalShare share) const { return over_bounds_[index(share)]; }
  // Every message dropped since it was opened: past the bounds, and unreadable.
  [[nodiscard]] std::uint64_t dropped() const;
  [[nodiscard]] const std::string& dir() const { return dir_; }

 private:
  struct File {
    std::uint64_t seq;
    std::size_t bytes;
  };
  using Files = std::deque<File>;
  static constexpr std::size_t index(JournalShare s) { return static_cast<std::size_t>(s); }
  [[nodiscard]] std::string path_of(std::uint64_t seq, JournalShare share) const;
  [[nodiscard]] std::optional<JournalShare> oldest() const;  // the share whose front was made first
  [[nodiscard]] bool over_bounds() const;
  void remove_front(JournalShare share);

  std::string dir_;
  JournalBounds bounds_;
  std::array<Files, journal_share_count> files_;  // each in the order made
  std::array<std::size_t, journal_share_count> bytes_{};
  std::uint64_t next_seq_ = 1;
  std::size_t taken_up_ = 0;
  std::uint64_t unreadable_ = 0;
  JournalDrops over_bounds_{};
};

// The text of one journal file and back (format "guideway/mqtt-journal/1", docs/formats.md). The
// share is not in the text: it is in the file's name.
std::string encode_journal_entry(const JournalEntry& entry);
std::optional<JournalEntry> decode_journal_entry(std::string_view text);

}  // namespace guideway::plant
