// The publisher's on-disk queue of unacknowledged QoS 1 messages (message_journal.hpp).
#include "plant/message_journal.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "core/atomic_file.hpp"
#include "core/csv_table.hpp"

namespace guideway::plant {

namespace {

constexpr std::string_view magic = "guideway/mqtt-journal/1";
constexpr std::string_view suffix = ".msg";

}  // namespace

// Four lines, then the payload as it is (it may hold any bytes):
//   guideway/mqtt-journal/1
//   TOPIC
//   retain=0|1 produced_utc=TIME
//   payload_bytes=N
//   PAYLOAD
std::string encode_journal_entry(const JournalEntry& e) {
  std::string text;
  text.reserve(e.payload.size() + e.topic.size() + 96);
  text.append(magic).append("\n").append(e.topic).append("\n");
  text.append("retain=").append(e.retain ? "1" : "0").append(" produced_utc=").append(e.produced_utc).append("\n");
  text.append("payload_bytes=").append(std::to_string(e.payload.size())).append("\n").append(e.payload);
  return text;
}

std::optional<JournalEntry> decode_journal_entry(std::string_view text) {
  const auto line = [&](std::string_view& out) {
    const auto nl = text.find('\n');
    if (nl == std::string_view::npos) return false;
    out = text.substr(0, nl);
    text.remove_prefix(nl + 1);
    return true;
  };
  std::string_view head, topic, flags, size;
  if (!line(head) || head != magic || !line(topic) || topic.empty() || !line(flags) || !line(size)) return std::nullopt;
  JournalEntry e;
  e.topic = std::string(topic);
  if (flags.starts_with("retain=1 ")) {
    e.retain = true;
  } else if (!flags.starts_with("retain=0 ")) {
    return std::nullopt;
  }
  flags.remove_prefix(9);
  if (!flags.starts_with("produced_utc=")) return std::nullopt;
  e.produced_utc = std::string(flags.substr(13));
  if (!size.starts_with("payload_bytes=")) return std::nullopt;
  size.remove_prefix(14);
  std::size_t n = 0;
  const auto [end, ec] = std::from_chars(size.data(), size.data() + size.size(), n);
  if (ec != std::errc() || end != size.data() + size.size() || n != text.size()) return std::nullopt;
  e.payload = std::string(text);
  return e;
}

std::string_view to_string(JournalShare share) noexcept {
  switch (share) {
    case JournalShare::events:
      return "events";
    case JournalShare::transitions:
      return "transitions";
    case JournalShare::results:
      return "results";
  }
  return "?";
}

namespace {

// A file's name says its share: NNN.event.msg, NNN.transition.msg, NNN.msg (a result; the journal of a
// release before the shares has only these).
constexpr std::array<std::string_view, journal_share_count> share_suffix = {".event", ".transition", ""};

bool parse_name(std::string_view name, std::uint64_t& seq, JournalShare& share) {
  if (!name.ends_with(suffix)) return false;
  name.remove_suffix(suffix.size());
  share = JournalShare::results;
  for (std::size_t i = 0; i + 1 < share_suffix.size(); ++i) {
    if (name.ends_with(share_suffix[i])) {
      share = static_cast<JournalShare>(i);
      name.remove_suffix(share_suffix[i].size());
      break;
    }
  }
  const auto [end, err] = std::from_chars(name.data(), name.data() + name.size(), seq);
  return err == std::errc() && end == name.data() + name.size();
}

}  // namespace

MessageJournal::MessageJournal(std::string dir, JournalBounds bounds) : dir_(std::move(dir)), bounds_(bounds) {
  bounds_.max_messages = std::max<std::size_t>(1, bounds_.max_messages);
  bounds_.max_event_messages = std::max<std::size_t>(1, bounds_.max_event_messages);
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec) throw std::runtime_error("MQTT journal " + dir_ + ": cannot create it: " + ec.message());
  ::chmod(dir_.c_str(), 0700);  // payloads may name the plant's machines and results
  for (const auto& entry : fs::directory_iterator(dir_, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.ends_with(".part")) {  // a write a crash cut short: never acknowledged as queued
      fs::remove(entry.path(), ec);
      continue;
    }
    std::uint64_t seq = 0;
    JournalShare share = JournalShare::results;
    if (!parse_name(name, seq, share)) continue;
    files_[index(share)].push_back({seq, static_cast<std::size_t>(entry.file_size(ec))});
  }
  if (ec) throw std::runtime_error("MQTT journal " + dir_ + ": cannot read it: " + ec.message());
  for (std::size_t i = 0; i < journal_share_count; ++i) {
    std::sort(files_[i].begin(), files_[i].end(), [](const File& a, const File& b) { return a.seq < b.seq; });
    for (const File& f : files_[i]) bytes_[i] += f.bytes;
    if (!files_[i].empty()) next_seq_ = std::max(next_seq_, files_[i].back().seq + 1);
  }
  taken_up_ = size();
}

std::size_t MessageJournal::size() const {
  std::size_t n = 0;
  for (const Files& f : files_) n += f.size();
  return n;
}

std::size_t MessageJournal::bytes() const {
  std::size_t n = 0;
  for (std::size_t b : bytes_) n += b;
  return n;
}

std::uint64_t MessageJournal::dropped() const {
  std::uint64_t n = unreadable_;
  for (std::uint64_t d : over_bounds_) n += d;
  return n;
}

std::string MessageJournal::path_of(std::uint64_t seq, JournalShare share) const {
  char name[32];
  std::snprintf(name, sizeof(name), "%020llu", static_cast<unsigned long long>(seq));
  return dir_ + "/" + name + std::string(share_suffix[index(share)]) + std::string(suffix);
}

std::optional<JournalShare> MessageJournal::oldest() const {
  std::optional<JournalShare> best;
  for (std::size_t i = 0; i < journal_share_count; ++i) {
    if (!files_[i].empty() && (!best || files_[i].front().seq < files_[index(*best)].front().seq))
      best = static_cast<JournalShare>(i);
  }
  return best;
}

bool MessageJournal::over_bounds() const { return size() > bounds_.max_messages || bytes() > bounds_.max_bytes; }

JournalDrops MessageJournal::push(const JournalEntry& entry) {
  const std::string text = encode_journal_entry(entry);
  write_file_atomically(path_of(next_seq_, entry.share), text, 0600);
  files_[index(entry.share)].push_back({next_seq_++, text.size()});
  bytes_[index(entry.share)] += text.size();
  JournalDrops dropped{};
  const auto drop = [&](JournalShare s) {
    remove_front(s);
    ++dropped[index(s)];
  };
  // The events' own share first: a flood of them never takes more than it.
  const std::size_t ev = index(JournalShare::events);
  while (files_[ev].size() > bounds_.max_event_messages ||
         (files_[ev].size() > 1 && bytes_[ev] > bounds_.max_event_bytes))
    drop(JournalShare::events);
  // Then the whole: the first share in the order of eviction that has a message gives up its oldest.
  // The newest message is kept even when it alone is over max_bytes: a bound on the backlog, not on a message.
  while (size() > 1 && over_bounds()) {
    for (std::size_t i = 0; i < journal_share_count; ++i) {
      if (files_[i].empty()) continue;
      drop(static_cast<JournalShare>(i));
      break;
    }
  }
  for (std::size_t i = 0; i < journal_share_count; ++i) over_bounds_[i] += dropped[i];
  return dropped;
}

std::optional<JournalEntry> MessageJournal::front() {
  while (const std::optional<JournalShare> share = oldest()) {
    try {
      if (auto e = decode_journal_entry(read_text_file(path_of(files_[index(*share)].front().seq, *share)))) {
        e->share = *share;
        return e;
      }
    } catch (const std::runtime_error&) {  // gone or unreadable: as a damaged file
    }
    remove_front(*share);
    ++unreadable_;
  }
  return std::nullopt;
}

void MessageJournal::pop_front() {
  if (const std::optional<JournalShare> share = oldest()) remove_front(*share);
}

void MessageJournal::remove_front(JournalShare share) {
  Files& files = files_[index(share)];
  std::remove(path_of(files.front().seq, share).c_str());
  bytes_[index(share)] -= files.front().bytes;
  files.pop_front();
}

}  // namespace guideway::plant
