#pragma once
// JSON Lines server over a Unix socket and optionally TCP. Reads newline-terminated requests
// (capped in length), hands each line to the request handler, and writes replies through a bounded
// per-client queue: a client that stops reading is dropped when its queue overflows, never waited for.
// Single-threaded: runs on the daemon's EventLoop.

#include <sys/types.h>

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "daemon/event_loop.hpp"

namespace guideway::daemon {

struct SocketServerOptions {
  std::string unix_path;           // empty: no Unix socket
  mode_t unix_mode = 0660;
  std::string unix_group;          // empty: the daemon's group
  std::string tcp_host = "127.0.0.1";
  int tcp_port = 0;                // 0: no TCP listener
  std::size_t max_request_bytes = 16 * 1024;
  std::size_t max_queue_bytes = 4 * 1024 * 1024;
  std::size_t max_clients = 256;
  // The last `reserved_clients` places are kept for connections from root and from the daemon's own
  // user or group (on the Unix socket), so idle or hostile clients cannot lock the operator out.
  std::size_t reserved_clients = 8;
};

using ClientId = std::uint64_t;

// True when something accepts connections on the Unix socket `path` (a running daemon), or may (a
// full backlog, a socket this user may not connect to); false for no file or a socket file a dead
// daemon left.
bool unix_socket_answers(const std::string& path);

class SocketServer {
 public:
  // Called for every complete request line (without the newline).
  using RequestHandler = std::function<void(ClientId, const std::string& line)>;
  using ConnectHandler = std::function<void(ClientId)>;
  // Called when a client goes, with why ("closed by peer", "queue overflow (...)", ...).
  using DisconnectHandler = std::function<void(ClientId, const std::string& reason)>;
  // Called for a request line that was too long (the server discards it and answers via this).
  // A request line over max_request_bytes: `bytes` of it when its newline came (`whole`), else as soon as
  // the limit is passed, without waiting for a newline that may never come; its rest is discarded
  // (one reply a line either way).
  using OversizeHandler = std::function<void(ClientId, std::size_t bytes, bool whole)>;

  SocketServer(EventLoop& loop, SocketServerOptions options);
  ~SocketServer();
  SocketServer(const SocketServer&) = delete;
  SocketServer& operator=(const SocketServer&) = delete;

  void on_request(RequestHandler h) { on_request_ = std::move(h); }
  void on_connect(ConnectHandler h) { on_connect_ = std::move(h); }
  void on_disconnect(DisconnectHandler h) { on_disconnect_ = std::move(h); }
  void on_oversize(OversizeHandler h) { on_oversize_ = std::move(h); }

  // Queues one line (a newline is appended) and writes it at once, or when the current batch ends.
  // Returns false if the client is gone or was dropped.
  bool send(ClientId client, std::string line);
  // While a Batch lives, send() only queues; its end writes each client's queue with one sendmsg()
  // (the fan-out of an outbox batch: one system call per client instead of one per message).
  class Batch {
   public:
    explicit Batch(SocketServer& server) : server_(server) { ++server_.batch_depth_; }
    ~Batch() {
      if (--server_.batch_depth_ == 0) server_.flush_batched();
    }
    Batch(const Batch&) = delete;
    Batch& operator=(const Batch&) = delete;

   private:
    SocketServer& server_;
  };
  void disconnect(ClientId client, const std::string& reason);
  [[nodiscard]] std::size_t client_count() const noexcept { return clients_.size(); }
  [[nodiscard]] std::size_t queued_bytes(ClientId client) const;
  [[nodiscard]] const std::string& unix_path() const noexcept { return options_.unix_path; }
  [[nodiscard]] int tcp_port() const noexcept { return bound_tcp_port_; }  // the real port (for port 0 = any)
  [[nodiscard]] std::uint64_t dropped_clients() const noexcept { return dropped_clients_; }
  // Closes every client that has not completed a request within `timeout_ns` of connecting.
  void close_idle(std::int64_t now_ns, std::int64_t timeout_ns);

 private:
  struct Client {
    int fd = -1;
    std::string inbox;
    bool discarding = false;  // inside an oversize line: skip to the next newline
    std::deque<std::string> outbox;
    std::size_t out_offset = 0;  // bytes of outbox.front() already written
    std::size_t queued = 0;
    bool want_write = false;
    bool flush_pending = false;  // queued during a Batch, not written yet
    std::int64_t connected_ns = 0;
    bool served = false;   // completed a request line
  };

  void listen_unix();
  void listen_tcp();
  void accept_on(int listen_fd);
  void read_from(ClientId id);
  void flush(ClientId id);
  void flush_batched();
  void close_client(ClientId id, const std::string& reason);

  EventLoop& loop_;
  SocketServerOptions options_;
  int unix_fd_ = -1;
  int tcp_fd_ = -1;
  int bound_tcp_port_ = 0;
  ClientId next_id_ = 1;
  std::unordered_map<ClientId, Client> clients_;
  std::uint64_t dropped_clients_ = 0;
  int batch_depth_ = 0;
  std::vector<ClientId> batched_;  // clients with flush_pending, in order
  RequestHandler on_request_;
  ConnectHandler on_connect_;
  DisconnectHandler on_disconnect_;
  OversizeHandler on_oversize_;
};

}  // namespace guideway::daemon
