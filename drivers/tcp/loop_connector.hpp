#pragma once
// One TCP connection attempt on an I/O loop (drivers/io_loop.hpp) without ever blocking it: the host
// is resolved (a name off the loop), then each address is tried in turn with a non-blocking connect
// and a timeout each. The owner (a loop-driven driver) gets the connected socket or the last error,
// and keeps its own back-off between attempts. Used on the loop's thread only.

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "drivers/io_loop.hpp"
#include "drivers/tcp/tcp_client.hpp"

namespace guideway::drivers::tcp {

class LoopConnector {
 public:
  using Connected = std::function<void(int fd)>;                 // the owner takes the socket (not watched by the loop)
  using Failed = std::function<void(const std::string& error)>;  // "LABEL: why"

  LoopConnector() = default;
  LoopConnector(const LoopConnector&) = delete;
  LoopConnector& operator=(const LoopConnector&) = delete;

  void attach(IoLoop& loop, Connected connected, Failed failed);
  void detach();  // an attempt under way is abandoned, its socket closed

  // Starts an attempt; `label` names the peer in errors (e.g. "tcp 127.0.0.1:1502 unit 1"). The
  // callbacks may run before start returns (a numeric address that connects at once).
  void start(const std::string& host, int port, std::string label, std::chrono::nanoseconds timeout);
  void cancel();
  [[nodiscard]] bool busy() const noexcept { return step_ != Step::idle; }

 private:
  enum class Step { idle, resolving, connecting };
  void on_timer();
  void on_writable();
  void next_address();
  void close_socket();
  void succeed();
  void fail(const std::string& error);

  IoLoop* io_ = nullptr;
  IoLoop::Id timer_ = 0;
  Connected connected_;
  Failed failed_;
  Step step_ = Step::idle;
  Resolver resolver_;
  std::vector<Address> addresses_;
  std::size_t next_ = 0;
  std::string label_;
  std::string error_;
  std::chrono::nanoseconds timeout_{0};
  int fd_ = -1;
  std::int64_t deadline_ns_ = 0;
};

}  // namespace guideway::drivers::tcp
