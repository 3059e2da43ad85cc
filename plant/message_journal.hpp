#pragma once
// The publisher's queue of QoS 1 messages not yet acknowledged by the broker, on disk (one file per
// message in a directory of the state directory) so that a broker outage and a restart of the daemon
// lose nothing. Bounded in messages and bytes: past a bound the oldest message is dropped and counted.
// Not thread safe (the publisher's thread owns it).

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>

namespace guideway::plant {

struct JournalEntry {
  std::string topic;
  std::string payload;
  std::string produced_utc;  // when the daemon made it (ISO 8601 UTC, ms)
  bool retain = false;
};

class MessageJournal {
 public:
  // Creates `dir` (0700) when missing and takes up the messages a previous run left there, oldest
  // first. Throws std::runtime_error naming the directory when it cannot be used.
  MessageJournal(std::string dir, std::size_t max_messages, std::size_t max_bytes);

  // Appends `entry` (written to disk before this returns); returns how many old messages were dropped
  // to stay within the bounds. Throws std::runtime_error when the file cannot be written (disk full).
  std::size_t push(const JournalEntry& entry);
  // The oldest message (read from its file), or nullopt when empty. A file that cannot be read back
  // (truncated by a crash, edited) is removed and counted in unreadable().
  std::optional<JournalEntry> front();
  void pop_front();

  [[nodiscard]] std::size_t size() const { return files_.size(); }
  [[nodiscard]] std::size_t bytes() const { return bytes_; }
  [[nodiscard]] std::size_t taken_up() const { return taken_up_; }  // messages found at start
  [[nodiscard]] std::uint64_t unreadable() const { return unreadable_; }
  // Every message dropped since it was opened: past the bounds, and unreadable.
  [[nodiscard]] std::uint64_t dropped() const { return over_bounds_ + unreadable_; }
  [[nodiscard]] const std::string& dir() const { return dir_; }

 private:
  struct File {
    std::uint64_t seq;
    std::size_t bytes;
  };
  [[nodiscard]] std::string path_of(std::uint64_t seq) const;
  void remove_front();

  std::string dir_;
  std::size_t max_messages_;
  std::size_t max_bytes_;
  std::deque<File> files_;
  std::size_t bytes_ = 0;
  std::uint64_t next_seq_ = 1;
  std::size_t taken_up_ = 0;
  std::uint64_t unreadable_ = 0;
  std::uint64_t over_bounds_ = 0;
};

// The text of one journal file and back (format "guideway/mqtt-journal/1", docs/formats.md).
std::string encode_journal_entry(const JournalEntry& entry);
std::optional<JournalEntry> decode_journal_entry(std::string_view text);

}  // namespace guideway::plant
