#pragma once
// TCP for loop-driven drivers (drivers/io_loop.hpp): resolving a host name without blocking the
// loop, a non-blocking connect, and reads that never wait and carry the kernel's receive time.
// Nothing here blocks (but Resolver's helper thread), prints or throws: errors go back as text.

#include <sys/socket.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace guideway::drivers::tcp {

struct Address {
  sockaddr_storage storage{};
  socklen_t length = 0;
};

// Resolves host:port: a numeric address at once, a name on a helper thread (getaddrinfo may wait
// seconds for DNS, which must not stall the other devices of the loop). Owned by one thread; a
// lookup still running when it is restarted or destroyed finishes unseen.
class Resolver {
 public:
  Resolver();
  ~Resolver();
  Resolver(const Resolver&) = delete;
  Resolver& operator=(const Resolver&) = delete;
  void start(const std::string& host, int port);
  // True once the lookup is done: `addresses` (at least one) or `error` ("host: Name or service not known").
  bool done(std::vector<Address>& addresses, std::string& error);
  void cancel() noexcept;

 private:
  struct State;
  std::shared_ptr<State> state_;
};

// Starts connecting a non-blocking socket to `address`; -1 with `error` when that fails at once.
// `connected` says the connection is already made; else wait until the socket is writable and ask
// connect_error().
int start_connect(const Address& address, bool& connected, std::string& error);
// After the socket became writable (or failed): 0 when connected, else the errno of the failure.
int connect_error(int fd) noexcept;
// TCP_NODELAY, and the kernel's receive time with every read (SO_TIMESTAMPNS).
void set_stream_options(int fd) noexcept;

enum class ReadStatus { data, would_block, closed, error };
struct ReadResult {
  ReadStatus status = ReadStatus::data;
  std::size_t bytes = 0;
  // With set_stream_options: when the kernel received the newest segment of the bytes read
  // (CLOCK_REALTIME ns), else no_rx_timestamp.
  std::int64_t rx_realtime_ns = INT64_MIN;
  std::string message;  // closed, error: why
};
inline constexpr std::int64_t no_rx_timestamp = INT64_MIN;
// Reads what is there, at most size bytes, never waiting.
ReadResult read_some(int fd, char* buffer, std::size_t size) noexcept;

}  // namespace guideway::drivers::tcp
