#pragma once
// A TCP client byte stream for drivers: connect with a timeout, read with a timeout, and an
// interrupt that wakes a blocked connect/read from another thread (so Driver::stop is prompt).
// Thread safety: one owner thread for connect/read/close; interrupt() from any thread.

#include <chrono>
#include <cstddef>
#include <string>

namespace guideway::drivers::tcp {

enum class ReadStatus { data, timeout, closed, error, interrupted };

struct ReadResult {
  ReadStatus status = ReadStatus::data;
  std::size_t bytes = 0;
  std::string message;  // for error/closed
};

class TcpClient {
 public:
  TcpClient();
  ~TcpClient();
  TcpClient(const TcpClient&) = delete;
  TcpClient& operator=(const TcpClient&) = delete;

  // Resolves host (name or address) and connects; false with error set on failure or interrupt.
  bool connect(const std::string& host, int port, std::chrono::milliseconds timeout, std::string& error);
  void close() noexcept;
  [[nodiscard]] bool connected() const noexcept { return fd_ >= 0; }
  // Waits up to timeout for bytes and reads what is there (at most size).
  ReadResult read_some(char* buffer, std::size_t size, std::chrono::milliseconds timeout) noexcept;
  // Wakes a blocked connect/read (it returns interrupted) until clear_interrupt().
  void interrupt() noexcept;
  void clear_interrupt() noexcept;

 private:
  int fd_ = -1;
  int wake_fd_ = -1;  // eventfd
};

}  // namespace guideway::drivers::tcp
