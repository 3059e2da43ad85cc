// The raw recorder (recorder.hpp): a session's samples through its own ring to NAME.csv.part by a writer thread.
#include "sessions/recorder.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <stdexcept>

#include "core/mono_clock.hpp"
#include "core/utc_time.hpp"
#include "formats/raw_recording.hpp"

namespace guideway::sessions {

RawRecorder::RawRecorder(const std::string& dir, const std::string& name, const drivers::Driver& device,
                         const std::map<std::string, std::string>& metadata, RecorderOptions options)
    : part_path_(formats::raw_recording_part_path(dir, name)),
      final_path_(formats::raw_recording_path(dir, name)),
      channel_count_(device.channels().size()),
      options_(options),
      ring_(options.ring_capacity.value_or(device.ring_capacity())),
      batch_(1024) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw std::runtime_error("cannot create recording directory " + dir + ": " + ec.message());
  fd_ = ::open(part_path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, recording_file_mode);
  if (fd_ < 0) throw std::runtime_error("cannot create recording " + part_path_ + ": " + std::strerror(errno));
  formats::RawRecordingHeader header;
  header.device = device.name();
  header.driver = device.driver();
  header.started_utc = utc_now_iso_ms();
  header.started_mono_ns = mono_now_ns();
  header.metadata = metadata;
  for (const auto& c : device.channels()) header.channels.push_back({c.name, c.unit});
  pending_ = formats::format_raw_header(header);
  write_pending();  // the header is on disk before the first sample
  thread_ = std::jthread([this](std::stop_token stop) { run(stop); });
}

RawRecorder::~RawRecorder() {
  try {
    close(false);
  } catch (...) {  // a destructor reports nothing; close() explicitly to learn the outcome
  }
}

void RawRecorder::push(std::span<const Sample> samples) noexcept {
  const std::size_t n = ring_.push_bulk(samples);
  pushed_.fetch_add(n, std::memory_order_relaxed);
}

void RawRecorder::run(const std::stop_token& stop) {
  while (!stop.stop_requested()) {
    std::this_thread::sleep_for(options_.flush_period);
    drain_and_write();
  }
}

void RawRecorder::drain_and_write() {
  for (;;) {
    const std::size_t n = ring_.pop_bulk(batch_);
    if (n == 0) break;
    if (pending_.size() > options_.max_pending_bytes) {
      std::lock_guard lock(stats_mutex_);
      stats_.samples_lost += n;  // the disk has refused writes for long: memory is bounded
      continue;
    }
    for (std::size_t i = 0; i < n; ++i) formats::append_raw_row(pending_, batch_[i], channel_count_);
    std::lock_guard lock(stats_mutex_);
    stats_.samples_written += n;
  }
  write_pending();
}

void RawRecorder::write_pending() {
  std::size_t off = 0;
  while (off < pending_.size()) {
    const ssize_t w = ::write(fd_, pending_.data() + off, pending_.size() - off);
    if (w < 0) {
      if (errno == EINTR) continue;
      std::lock_guard lock(stats_mutex_);
      ++stats_.write_errors;
      error_ = "writing " + part_path_ + ": " + std::strerror(errno);
      error_count_.fetch_add(1, std::memory_order_relaxed);
      break;
    }
    off += static_cast<std::size_t>(w);
  }
  pending_.erase(0, off);
  std::lock_guard lock(stats_mutex_);
  stats_.bytes_written += off;
  if (off != 0 && pending_.empty()) error_.clear();
}

std::string RawRecorder::close(bool complete, const std::map<std::string, std::string>& trailer) {
  if (closed_) return complete ? final_path_ : part_path_;
  closed_ = true;
  thread_.request_stop();
  if (thread_.joinable()) thread_.join();
  drain_and_write();
  const RecorderStats s = stats();
  pending_ += formats::format_raw_trailer({.complete = complete,
                                           .ended_utc = utc_now_iso_ms(),
                                           .samples = s.samples_written,
                                           .samples_lost = s.samples_lost,  // stats() counts the ring's drops
                                           .metadata = trailer});
  write_pending();
  const bool written = pending_.empty();
  const bool synced = ::fsync(fd_) == 0;
  const int sync_errno = errno;
  ::close(fd_);
  fd_ = -1;
  if (!written || !synced) {
    std::lock_guard lock(stats_mutex_);
    if (error_.empty()) error_ = "syncing " + part_path_ + ": " + std::strerror(sync_errno);
    error_count_.fetch_add(1, std::memory_order_relaxed);
    return part_path_;  // left as .part: incomplete on disk
  }
  if (std::rename(part_path_.c_str(), final_path_.c_str()) != 0) {
    std::lock_guard lock(stats_mutex_);
    error_ = "renaming " + part_path_ + ": " + std::strerror(errno);
    error_count_.fetch_add(1, std::memory_order_relaxed);
    return part_path_;
  }
  // Make the rename itself durable.
  const std::string dir = std::filesystem::path(final_path_).parent_path().string();
  if (const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
  return final_path_;
}

RecorderStats RawRecorder::stats() const {
  std::lock_guard lock(stats_mutex_);
  RecorderStats s = stats_;
  s.samples_lost += ring_.drops();
  return s;
}

std::string RawRecorder::error() const {
  std::lock_guard lock(stats_mutex_);
  return error_;
}

}  // namespace guideway::sessions
