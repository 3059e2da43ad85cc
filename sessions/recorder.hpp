#pragma once
// Records one device's raw samples of one session to a CSV file (docs/formats.md, guideway/raw/1)
// as they arrive, without blocking the pipeline: the pipeline pushes into an SPSC ring, a writer
// thread formats and write()s at least every `flush_period` (so a killed daemon leaves a readable
// file ending at most that long before the kill), and close() appends the end marker, fsyncs and
// renames NAME.csv.part to NAME.csv. Disk errors are reported (state(), error()), never thrown at
// the pipeline; data is kept in memory up to a cap and written when the disk accepts it again.
// Thread safety: push() from one producer thread; everything else from the owning thread.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <span>
#include <stop_token>
#include <string>
#include <thread>
#include <vector>

#include "core/sample.hpp"
#include "core/spsc_ring.hpp"
#include "drivers/driver.hpp"

namespace guideway::sessions {

// Every file a session leaves (raw recording, derived, explain, report): rw for the daemon, r for its
// group, whatever the umask.
inline constexpr unsigned recording_file_mode = 0640;

struct RecorderOptions {
  std::chrono::milliseconds flush_period{50};
  // nullopt: as many samples as the device's own ring (8 s of its full rate, drivers/ring_capacity.hpp). The
  // writer empties it every flush_period; one held up longer than the ring lasts (a busy machine, a write()
  // the kernel holds back for a slow disk) loses samples, counted (samples_lost, the trailer).
  std::optional<std::size_t> ring_capacity;
  std::size_t max_pending_bytes = 64u << 20;  // memory kept while the disk refuses writes
};

struct RecorderStats {
  std::uint64_t samples_written = 0;
  std::uint64_t samples_lost = 0;  // ring overruns or pending data beyond the cap
  std::uint64_t bytes_written = 0;
  std::uint64_t write_errors = 0;
};

class RawRecorder {
 public:
  // Creates DIR/NAME.csv.part with its metadata header. Throws std::runtime_error naming the path
  // when the file cannot be created (the caller reports it and goes on without recording).
  RawRecorder(const std::string& dir, const std::string& name, const drivers::Driver& device,
              const std::map<std::string, std::string>& metadata, RecorderOptions options = {});
  ~RawRecorder();
  RawRecorder(const RawRecorder&) = delete;
  RawRecorder& operator=(const RawRecorder&) = delete;

  void push(std::span<const Sample> samples) noexcept;
  // Writes what is left, the end marker (`# end = complete|aborted`), fsyncs, renames. Returns the
  // final path. Idempotent.
  std::string close(bool complete, const std::map<std::string, std::string>& trailer = {});

  [[nodiscard]] RecorderStats stats() const;
  [[nodiscard]] std::string error() const;  // last disk error, "" if none
  // Disk errors so far: cheap to poll from the pipeline (error() takes a lock) to report one at once.
  [[nodiscard]] std::uint64_t error_count() const noexcept { return error_count_.load(std::memory_order_relaxed); }
  [[nodiscard]] const std::string& part_path() const noexcept { return part_path_; }
  [[nodiscard]] const std::string& final_path() const noexcept { return final_path_; }

 private:
  void run(const std::stop_token& stop);
  void drain_and_write();
  void write_pending();

  std::string part_path_;
  std::string final_path_;
  std::size_t channel_count_;
  RecorderOptions options_;
  int fd_ = -1;
  SpscRing<Sample> ring_;
  std::string pending_;  // writer thread only (and close() after the thread stopped)
  std::vector<Sample> batch_;
  mutable std::mutex stats_mutex_;
  RecorderStats stats_;
  std::string error_;
  std::atomic<std::uint64_t> pushed_{0};
  std::atomic<std::uint64_t> error_count_{0};
  bool closed_ = false;
  std::jthread thread_;
};

}  // namespace guideway::sessions
