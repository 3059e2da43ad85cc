// The JSON Lines server on a Unix socket and optionally TCP (socket_server.hpp).
#include "daemon/socket_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <grp.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <sys/un.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "core/mono_clock.hpp"
#include "core/runtime_paths.hpp"

namespace guideway::daemon {

namespace {

[[noreturn]] void throw_errno(const std::string& what) { throw std::system_error(errno, std::generic_category(), what); }

}  // namespace

bool unix_socket_answers(const std::string& path) {
  sockaddr_un addr{};
  if (path.size() >= sizeof(addr.sun_path)) return false;
  const int probe = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (probe < 0) return false;
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  // Dead only when the kernel says nobody listens (ECONNREFUSED) or there is no file (ENOENT): a full
  // backlog (EAGAIN; never waited on) or a socket this user may not open (EACCES) is a live daemon.
  const bool dead = connect(probe, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 &&
                    (errno == ECONNREFUSED || errno == ENOENT);
  close(probe);
  return !dead;
}

SocketServer::SocketServer(EventLoop& loop, SocketServerOptions options) : loop_(loop), options_(std::move(options)) {
  if (!options_.unix_path.empty()) listen_unix();
  if (options_.tcp_port != 0) listen_tcp();
}

SocketServer::~SocketServer() {
  while (!clients_.empty()) close_client(clients_.begin()->first, "server shutting down");
  if (unix_fd_ >= 0) {
    loop_.remove(unix_fd_);
    close(unix_fd_);
    ::unlink(options_.unix_path.c_str());
  }
  if (tcp_fd_ >= 0) {
    loop_.remove(tcp_fd_);
    close(tcp_fd_);
  }
}

void SocketServer::listen_unix() {
  const std::string& path = options_.unix_path;
  sockaddr_un addr{};
  if (const std::string problem = socket_path_problem(path); !problem.empty()) throw std::runtime_error(path + ": " + problem);
  secure_socket_directory(std::filesystem::path(path).parent_path().string());
  std::error_code ec;
  // A socket file left by a daemon that died: remove it only if nobody answers on it.
  if (std::filesystem::exists(path, ec)) {
    if (unix_socket_answers(path)) throw std::runtime_error("another daemon is already listening on " + path);
    ::unlink(path.c_str());
  }
  unix_fd_ = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (unix_fd_ < 0) throw_errno("socket(AF_UNIX)");
  // Bound under a temporary name, given its mode and group, listening, and only then renamed into
  // place: a client that sees the path can connect at once (between bind and listen a connect is
  // refused: clients that wait for the path to appear met that) and never finds the umask's mode.
  std::string bound = path + ".new";
  if (bound.size() >= sizeof(addr.sun_path)) bound = path;  // no room for the suffix: bound in place
  if (bound != path) ::unlink(bound.c_str());
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, bound.c_str(), bound.size() + 1);
  if (bind(unix_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) throw_errno("bind " + bound);
  if (chmod(bound.c_str(), options_.unix_mode) != 0) throw_errno("chmod " + bound);
  if (!options_.unix_group.empty()) {
    const group* g = getgrnam(options_.unix_group.c_str());
    if (!g) throw std::runtime_error("socket_group: no group named " + options_.unix_group);
    if (chown(bound.c_str(), static_cast<uid_t>(-1), g->gr_gid) != 0) throw_errno("chown " + bound);
  }
  if (listen(unix_fd_, 64) != 0) throw_errno("listen " + bound);
  if (bound != path && std::rename(bound.c_str(), path.c_str()) != 0) throw_errno("rename " + bound + " to " + path);
  loop_.add(unix_fd_, EPOLLIN, [this](std::uint32_t) { accept_on(unix_fd_); });
}

void SocketServer::listen_tcp() {
  tcp_fd_ = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (tcp_fd_ < 0) throw_errno("socket(AF_INET)");
  int one = 1;
  setsockopt(tcp_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(options_.tcp_port < 0 ? 0 : options_.tcp_port));
  if (inet_pton(AF_INET, options_.tcp_host.c_str(), &addr.sin_addr) != 1) {
    throw std::runtime_error("tcp_listen: not an IPv4 address: " + options_.tcp_host);
  }
  if (bind(tcp_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    throw_errno("bind " + options_.tcp_host + ":" + std::to_string(options_.tcp_port));
  }
  if (listen(tcp_fd_, 64) != 0) throw_errno("listen tcp");
  socklen_t len = sizeof(addr);
  getsockname(tcp_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  bound_tcp_port_ = ntohs(addr.sin_port);
  loop_.add(tcp_fd_, EPOLLIN, [this](std::uint32_t) { accept_on(tcp_fd_); });
}

void SocketServer::accept_on(int listen_fd) {
  for (;;) {
    const int fd = accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;  // EAGAIN, or a transient error: nothing to do until the next readiness
    bool trusted = false;
    if (listen_fd == unix_fd_) {
      ucred cred{};
      socklen_t len = sizeof cred;
      if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0)
        trusted = cred.uid == 0 || cred.uid == geteuid() || cred.gid == getegid();
    }
    const std::size_t open_to_all = options_.max_clients - std::min(options_.reserved_clients, options_.max_clients);
    if (clients_.size() >= options_.max_clients || (!trusted && clients_.size() >= open_to_all)) {
      static constexpr char busy[] =
          "{\"class\":\"ERROR\",\"message\":\"too many clients\"}\n";
      [[maybe_unused]] auto ignored = write(fd, busy, sizeof(busy) - 1);
      close(fd);
      continue;
    }
    const ClientId id = next_id_++;
    Client& client = clients_[id];
    client.fd = fd;
    client.connected_ns = mono_now_ns();
    loop_.add(fd, EPOLLIN | EPOLLRDHUP, [this, id](std::uint32_t events) {
      if (events & EPOLLERR) {
        close_client(id, "connection error");
        return;
      }
      if (events & EPOLLOUT) flush(id);
      // A hang-up is read like data: what the peer sent last is served, then read() returns 0.
      if (events & (EPOLLIN | EPOLLRDHUP | EPOLLHUP)) read_from(id);
    });
    if (on_connect_) on_connect_(id);
  }
}

void SocketServer::close_idle(std::int64_t now_ns, std::int64_t timeout_ns) {
  if (timeout_ns <= 0) return;
  std::vector<ClientId> idle;
  for (const auto& [id, c] : clients_)
    if (!c.served && now_ns - c.connected_ns > timeout_ns) idle.push_back(id);
  for (const ClientId id : idle)
    close_client(id, "no request within " + std::to_string(timeout_ns / 1'000'000'000) + " s of connecting");
}

void SocketServer::read_from(ClientId id) {
  std::array<char, 8192> buf{};
  for (;;) {
    auto it = clients_.find(id);
    if (it == clients_.end()) return;
    const ssize_t n = read(it->second.fd, buf.data(), buf.size());
    if (n == 0) {
      close_client(id, "closed by peer");
      return;
    }
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) return;
      if (errno == EINTR) continue;
      close_client(id, std::string("read error: ") + std::strerror(errno));
      return;
    }
    std::size_t start = 0;
    const auto len = static_cast<std::size_t>(n);
    while (start < len) {
      Client& c = clients_.at(id);
      const char* nl = static_cast<const char*>(std::memchr(buf.data() + start, '\n', len - start));
      const std::size_t end = nl ? static_cast<std::size_t>(nl - buf.data()) : len;
      if (c.discarding) {  // answered already: the rest of the line goes, up to its newline
        if (nl) c.discarding = false;
      } else {
        c.inbox.append(buf.data() + start, end - start);
        if (c.inbox.size() > options_.max_request_bytes) {
          const std::size_t bytes = c.inbox.size();
          c.inbox.clear();
          c.discarding = !nl;
          c.served = true;
          if (on_oversize_) on_oversize_(id, bytes, nl != nullptr);
        } else if (nl) {
          c.served = true;
          std::string line;
          line.swap(c.inbox);
          if (!line.empty() && line.back() == '\r') line.pop_back();
          if (on_request_) on_request_(id, line);  // an empty line too: every line gets one reply
        }
      }
      if (!clients_.contains(id)) return;  // a handler disconnected it
      start = end + 1;
    }
  }
}

bool SocketServer::send(ClientId id, std::string line) {
  auto it = clients_.find(id);
  if (it == clients_.end()) return false;
  line.push_back('\n');
  // A backlog marks a slow client, not one long line: the backlog is what already waits behind the
  // line being written, judged before this line joins it, so a client that keeps up takes any line,
  // even one longer than the whole queue (an EXPLAIN can be ~100 KB), also while its socket buffer is
  // still full of the last. The queue holds at most max_queue_bytes plus two lines.
  const auto overflows = [this](const Client& c) {
    const std::size_t behind = c.queued - (c.outbox.empty() ? 0 : c.outbox.front().size());
    return behind > options_.max_queue_bytes;
  };
  if (overflows(it->second) && !it->second.want_write) {
    // Lines a Batch only deferred are no backlog until the kernel refuses them: hand them over first.
    flush(id);
    it = clients_.find(id);
    if (it == clients_.end()) return false;
  }
  Client& c = it->second;
  if (overflows(c)) {
    ++dropped_clients_;
    close_client(id, "queue overflow (" + std::to_string(c.queued) + " bytes unread): client too slow");
    return false;
  }
  c.queued += line.size();
  c.outbox.push_back(std::move(line));
  // In a batch, defer the write; but never let a batch alone fill a reading client's queue (a long
  // outbox batch after a stall must not get a healthy client dropped): past a quarter, write now.
  if (batch_depth_ > 0 && c.queued <= options_.max_queue_bytes / 4) {
    if (!c.flush_pending && !c.want_write) {  // a client waiting for EPOLLOUT is flushed from there
      c.flush_pending = true;
      batched_.push_back(id);
    }
    return true;
  }
  flush(id);
  return clients_.contains(id);
}

void SocketServer::flush_batched() {
  std::vector<ClientId> ids;
  ids.swap(batched_);
  for (ClientId id : ids) {
    auto it = clients_.find(id);
    if (it == clients_.end()) continue;  // dropped meanwhile
    it->second.flush_pending = false;
    flush(id);
  }
}

void SocketServer::flush(ClientId id) {
  auto it = clients_.find(id);
  if (it == clients_.end()) return;
  Client& c = it->second;
  while (!c.outbox.empty()) {
    // Up to 64 queued lines per system call.
    std::array<iovec, 64> iov{};
    std::size_t n_iov = 0;
    for (auto line = c.outbox.begin(); line != c.outbox.end() && n_iov < iov.size(); ++line, ++n_iov) {
      const std::size_t skip = n_iov == 0 ? c.out_offset : 0;
      iov[n_iov] = {const_cast<char*>(line->data()) + skip, line->size() - skip};
    }
    msghdr msg{};
    msg.msg_iov = iov.data();
    msg.msg_iovlen = n_iov;
    const ssize_t n = ::sendmsg(c.fd, &msg, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) break;
      close_client(id, std::string("write error: ") + std::strerror(errno));
      return;
    }
    std::size_t written = static_cast<std::size_t>(n);
    while (written > 0) {
      const std::size_t rest = c.outbox.front().size() - c.out_offset;
      if (written < rest) {
        c.out_offset += written;
        break;
      }
      written -= rest;
      c.queued -= c.outbox.front().size();
      c.outbox.pop_front();
      c.out_offset = 0;
    }
  }
  const bool want_write = !c.outbox.empty();
  if (want_write != c.want_write) {
    c.want_write = want_write;
    loop_.modify(c.fd, EPOLLIN | EPOLLRDHUP | (want_write ? EPOLLOUT : 0u));
  }
}

std::size_t SocketServer::queued_bytes(ClientId id) const {
  auto it = clients_.find(id);
  return it == clients_.end() ? 0 : it->second.queued;
}

void SocketServer::disconnect(ClientId id, const std::string& reason) { close_client(id, reason); }

void SocketServer::close_client(ClientId id, const std::string& reason) {
  auto it = clients_.find(id);
  if (it == clients_.end()) return;
  loop_.remove(it->second.fd);
  close(it->second.fd);
  clients_.erase(it);
  if (on_disconnect_) on_disconnect_(id, reason);
}

}  // namespace guideway::daemon
