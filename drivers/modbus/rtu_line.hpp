#pragma once
// Modbus RTU for a driver on the I/O loop (drivers/loop_driver.hpp). libmodbus blocks for every request:
// a serial round trip (at 19200 baud some 140 ms for 125 registers), a whole response timeout when
// nothing answers, and more while it brings the line back in step (ModbusClient's probe and marker
// reads). The loop that serves every device must never wait so long, so the line has a thread of its
// own that does only that: it reads the batch of register blocks it is handed, in turn, and rings an
// eventfd when all are answered. The driver watches that descriptor as its transport (link_up(fd()));
// when to ask, the link's states, its back-off and what an answer means stay the driver's and the
// skeleton's. Opening a serial line does not block (an open and a tcsetattr), so open() runs on the
// caller's thread.
// Thread safety: every member from one thread (the loop's); the reads run on the line's thread, and
// the batch handed to ask() is the line's until answered() (or wait()) says it is done.

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "drivers/modbus/modbus_client.hpp"

namespace guideway::drivers::modbus {

// One register read asked for, and its answer.
struct RegisterRead {
  RegisterFunction function = RegisterFunction::input;
  std::uint16_t address = 0;
  std::uint16_t count = 0;
  ReadResult result;
  std::vector<std::uint16_t> block = std::vector<std::uint16_t>(125);
  std::int64_t t_answer_ns = 0;  // when the answer arrived (CLOCK_MONOTONIC)
};

class RtuLine {
 public:
  explicit RtuLine(ModbusEndpoint endpoint);  // throws std::system_error when no eventfd can be made
  ~RtuLine();
  RtuLine(const RtuLine&) = delete;
  RtuLine& operator=(const RtuLine&) = delete;

  // Opens the serial line and starts the line's thread; false with `error` when the line cannot be
  // opened. A line reopened is the same bus: what the client knows of it (an answer still owed, a
  // server that ignores the probe) is kept (ModbusClient::connect).
  bool open(std::string& error);
  // After the batch under way is answered: stops the thread and closes the line.
  void close() noexcept;
  // Readable (EPOLLIN) once a batch is answered; the same descriptor for every opening.
  [[nodiscard]] int fd() const noexcept { return event_fd_; }

  // Reads `reads` in turn, after discarding what the line holds when `flush_first` (late or stray
  // answers of an earlier poll). A failure the line causes (timeout, bad frame, a line gone) fails the
  // reads after it without asking them: they would fail the same way, a timeout each; after a Modbus
  // exception the next is asked. `reads` must stay alive and untouched until the batch is answered.
  void ask(std::span<RegisterRead> reads, bool flush_first);
  // Whether the batch asked is answered (then its reads are the caller's again); clears fd()'s readiness.
  bool answered();
  // Waits until the batch under way (if any) is answered.
  void wait();
  // Late answers the line discarded so far (ModbusClient::stale_answers), as of the last batch answered.
  [[nodiscard]] std::uint64_t stale_answers() const noexcept { return stale_answers_; }

 private:
  void serve();
  void read_batch(std::span<RegisterRead> reads, bool flush_first) noexcept;

  ModbusClient client_;  // the line's thread's while it runs
  int event_fd_ = -1;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  // Under mutex_:
  std::span<RegisterRead> batch_;
  bool flush_first_ = false;
  bool pending_ = false;   // a batch asked and not answered yet
  bool done_ = false;      // a batch answered and not taken by answered() yet
  bool stopping_ = false;
  std::uint64_t stale_seen_ = 0;
  // The loop's thread's:
  std::uint64_t stale_answers_ = 0;
};

}  // namespace guideway::drivers::modbus
