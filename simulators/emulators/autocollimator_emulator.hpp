#pragma once
// An emulated TA80-style autocollimator on a pseudo-terminal: answers "a"/"r"/"z"/"c"/"s" requests
// with the replies of autocollimator_protocol.hpp, its readings taken from an AutocollimatorSource
// (the virtual machine tool). A disconnect closes the pty and opens a new one; `link` (a symlink
// path, like /dev/serial/by-id/...) is removed while unplugged and then points to the new pty, so a
// driver can reopen it.
// Faults are injected from any thread; every reading sent is logged for the tests.
// Thread safe: start/stop from one thread; the rest from any thread.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drivers/autocollimator/autocollimator_protocol.hpp"

namespace guideway::simulators::emulators {

// What the instrument sees at t_s (seconds since start): the mirror's tilt about the two axes in
// arc-seconds, and whether the beam comes back at all.
struct AutocollimatorView {
  double x_arcsec = 0.0;
  double y_arcsec = 0.0;
  bool reflection = true;
};
using AutocollimatorSource = std::function<AutocollimatorView(double t_s)>;

struct AutocollimatorEmulatorSettings {
  double range_arcsec = 1000.0;
  bool checksum = false;
  std::string link;  // symlink to the current pty ("" = none)
};

struct AutocollimatorSentReading {
  double t_s = 0;
  drivers::autocollimator::Reading reading;  // as sent (rounded to 0.01", OVER/---- applied)
};

class AutocollimatorEmulator {
 public:
  AutocollimatorEmulator(AutocollimatorEmulatorSettings settings, AutocollimatorSource source);
  ~AutocollimatorEmulator();
  AutocollimatorEmulator(const AutocollimatorEmulator&) = delete;
  AutocollimatorEmulator& operator=(const AutocollimatorEmulator&) = delete;

  // Opens the pty and starts serving; false with `error` when no pty can be opened.
  bool start(std::string& error);
  void stop();
  // The slave path of the current pty (/dev/pts/N), or the link when one is configured.
  [[nodiscard]] std::string path() const;
  [[nodiscard]] std::string pty_path() const;
  // Called (on the emulator thread) with the new pty path after every (re)open.
  void on_reopen(std::function<void(const std::string&)> callback);

  void inject_disconnect(double down_seconds = 0.0);  // close the pty; reopen a new one after down_seconds
  void inject_garbage(int bytes);                     // random bytes, then a line end
  void inject_truncated(int lines);                   // a reply cut short, then a line end
  void inject_bad_checksum(int lines);                // a reply with a wrong checksum (or a corrupted status)
  void inject_stall(double seconds);                  // no replies, no stream for a while
  void inject_burst(int readings);                    // that many extra readings, back to back
  void inject_block(double seconds);                  // beam blocked: "----" (no reflection) for a while

  // Returns once the emulator thread has finished what it was doing at the call (a reading being
  // written then is in log() by now), so that after inject_stall() the log is final; false if the
  // thread made no pass within the timeout.
  bool settle(std::chrono::milliseconds timeout = std::chrono::seconds(10));

  [[nodiscard]] std::vector<AutocollimatorSentReading> log() const;
  [[nodiscard]] std::uint64_t requests() const noexcept { return requests_.load(); }
  [[nodiscard]] std::uint64_t opens() const noexcept { return opens_.load(); }
  [[nodiscard]] bool streaming() const noexcept { return stream_period_ms_.load() > 0; }

 private:
  bool open_pty(std::string& error);
  void close_pty();
  void loop();
  void send_reading(bool relative);
  void send_faults();
  void write_raw(const std::string& bytes);
  void handle_command(const std::string& line);

  AutocollimatorEmulatorSettings settings_;
  AutocollimatorSource source_;
  std::int64_t t0_ns_ = 0;
  int master_ = -1;
  int slave_keep_ = -1;  // keeps the slave side open so the master never reads EIO between clients
  mutable std::mutex path_mutex_;
  std::string pty_path_;
  std::function<void(const std::string&)> on_reopen_;
  int wake_fd_ = -1;
  std::jthread thread_;
  std::atomic<bool> running_{false};

  std::atomic<double> disconnect_down_s_{-1.0};
  std::atomic<int> garbage_{0}, truncated_{0}, bad_checksum_{0}, burst_{0};
  std::atomic<std::int64_t> stall_until_ns_{0};
  std::atomic<std::int64_t> block_until_ns_{0};
  std::atomic<std::int64_t> stream_period_ms_{0};
  double zero_x_ = 0, zero_y_ = 0;  // relative zero (emulator thread)
  std::uint32_t rng_ = 987654321u;

  mutable std::mutex log_mutex_;
  std::vector<AutocollimatorSentReading> log_;
  std::atomic<std::uint64_t> requests_{0};
  std::atomic<std::uint64_t> opens_{0};
  std::atomic<std::uint64_t> passes_{0};  // loop passes begun (settle())
};

}  // namespace guideway::simulators::emulators
