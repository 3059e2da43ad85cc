#include "plant/message_journal.hpp"

#include <sys/stat.h>

#include <algorithm>
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

MessageJournal::MessageJournal(std::string dir, std::size_t max_messages, std::size_t max_bytes)
    : dir_(std::move(dir)), max_messages_(std::max<std::size_t>(1, max_messages)), max_bytes_(max_bytes) {
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
    if (!name.ends_with(suffix)) continue;
    std::uint64_t seq = 0;
    const std::string_view digits(name.data(), name.size() - suffix.size());
    const auto [end, err] = std::from_chars(digits.data(), digits.data() + digits.size(), seq);
    if (err != std::errc() || end != digits.data() + digits.size()) continue;
    files_.push_back({seq, static_cast<std::size_t>(entry.file_size(ec))});
  }
  if (ec) throw std::runtime_error("MQTT journal " + dir_ + ": cannot read it: " + ec.message());
  std::sort(files_.begin(), files_.end(), [](const File& a, const File& b) { return a.seq < b.seq; });
  for (const File& f : files_) bytes_ += f.bytes;
  if (!files_.empty()) next_seq_ = files_.back().seq + 1;
  taken_up_ = files_.size();
}

std::string MessageJournal::path_of(std::uint64_t seq) const {
  char name[32];
  std::snprintf(name, sizeof(name), "%020llu", static_cast<unsigned long long>(seq));
  return dir_ + "/" + name + std::string(suffix);
}

std::size_t MessageJournal::push(const JournalEntry& entry) {
  const std::string text = encode_journal_entry(entry);
  write_file_atomically(path_of(next_seq_), text, 0600);
  files_.push_back({next_seq_++, text.size()});
  bytes_ += text.size();
  std::size_t dropped = 0;
  // The newest message is kept even when it alone is over max_bytes: a bound on the backlog, not on a message.
  while (files_.size() > 1 && (files_.size() > max_messages_ || bytes_ > max_bytes_)) {
    remove_front();
    ++dropped;
  }
  over_bounds_ += dropped;
  return dropped;
}

std::optional<JournalEntry> MessageJournal::front() {
  while (!files_.empty()) {
    try {
      if (auto e = decode_journal_entry(read_text_file(path_of(files_.front().seq)))) return e;
    } catch (const std::runtime_error&) {  // gone or unreadable: as a damaged file
    }
    remove_front();
    ++unreadable_;
  }
  return std::nullopt;
}

void MessageJournal::pop_front() {
  if (!files_.empty()) remove_front();
}

void MessageJournal::remove_front() {
  std::remove(path_of(files_.front().seq).c_str());
  bytes_ -= files_.front().bytes;
  files_.pop_front();
}

}  // namespace guideway::plant
