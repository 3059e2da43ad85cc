// A blocking JSON Lines client of guidewayd (daemon_client.hpp), over a Unix socket or TCP.
#include "cli/daemon_client.hpp"

#include "core/runtime_paths.hpp"

#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <stdexcept>

#include "core/mono_clock.hpp"

namespace guideway::cli {

namespace {

int connect_unix(const std::string& path) {
  sockaddr_un addr{};
  if (path.size() >= sizeof(addr.sun_path)) throw std::runtime_error(path + ": socket path too long");
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(path + ": socket: " + std::strerror(errno));
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  try {
    check_socket_owner(path);  // not a fake daemon another user put in our place
  } catch (...) {
    close(fd);
    throw;
  }
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    const int err = errno;
    close(fd);
    throw std::runtime_error(path + ": " + std::strerror(err));
  }
  return fd;
}

int connect_tcp(const std::string& host_port) {
  const std::string where = "tcp:" + host_port;
  const auto colon = host_port.rfind(':');
  if (colon == std::string::npos || colon == 0) throw std::runtime_error(where + ": expected tcp:HOST:PORT");
  std::string host = host_port.substr(0, colon);
  const std::string port = host_port.substr(colon + 1);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);  // [::1]
  unsigned port_number = 0;
  const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), port_number);
  if (port.empty() || ec != std::errc() || end != port.data() + port.size() || port_number == 0 || port_number > 65535) {
    throw std::runtime_error(where + ": the port must be a number from 1 to 65535");
  }
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;  // a name (localhost) or an IPv4/IPv6 address
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (const int r = getaddrinfo(host.c_str(), port.c_str(), &hints, &found); r != 0) {
    throw std::runtime_error(where + ": " + gai_strerror(r));
  }
  std::string error = "no address";
  for (const addrinfo* a = found; a; a = a->ai_next) {
    const int fd = socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
    if (fd >= 0 && connect(fd, a->ai_addr, a->ai_addrlen) == 0) {
      freeaddrinfo(found);
      return fd;
    }
    error = std::strerror(errno);
    if (fd >= 0) close(fd);
  }
  freeaddrinfo(found);
  throw std::runtime_error(where + ": " + error);
}

}  // namespace

DaemonClient::DaemonClient(const std::string& address) : address_(address) {
  fd_ = address.rfind("tcp:", 0) == 0 ? connect_tcp(address.substr(4)) : connect_unix(address);
  auto line = read_line(std::chrono::seconds(5));
  if (!line) throw std::runtime_error(address + ": no VERSION banner from the daemon");
  banner_ = nlohmann::json::parse(*line, nullptr, false);
  if (!banner_.is_discarded() && results::has_class(banner_, results::MessageClass::error)) {  // "too many clients"
    throw std::runtime_error(address + ": the daemon refused the connection: " + banner_.value("message", "?"));
  }
  if (banner_.is_discarded() || !results::has_class(banner_, results::MessageClass::version)) {
    throw std::runtime_error(address + ": not a guidewayd socket (first line: " + *line + ")");
  }
}

DaemonClient DaemonClient::connect_first(const std::vector<std::string>& candidates) {
  std::string errors;
  for (const auto& c : candidates) {
    try {
      return DaemonClient(c);
    } catch (const std::runtime_error& e) {
      errors += std::string("\n  ") + e.what();
    }
  }
  throw std::runtime_error("cannot reach guidewayd; tried:" + errors +
                           "\n  (is the daemon running? set --socket or $GUIDEWAY_SOCKET)");
}

DaemonClient::DaemonClient(DaemonClient&& other) noexcept
    : fd_(other.fd_), address_(std::move(other.address_)), buffer_(std::move(other.buffer_)), banner_(std::move(other.banner_)) {
  other.fd_ = -1;
}

DaemonClient::~DaemonClient() {
  if (fd_ >= 0) close(fd_);
}

void DaemonClient::send_line(const std::string& line) {
  std::string data = line + "\n";
  std::size_t off = 0;
  while (off < data.size()) {
    const ssize_t n = ::send(fd_, data.data() + off, data.size() - off, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error(address_ + ": write failed: " + std::strerror(errno));
    }
    off += static_cast<std::size_t>(n);
  }
}

std::optional<std::string> DaemonClient::read_line(std::chrono::milliseconds timeout) {
  const std::int64_t deadline = mono_now_ns() + timeout.count() * 1'000'000;
  for (;;) {
    if (auto nl = buffer_.find('\n'); nl != std::string::npos) {
      std::string line = buffer_.substr(0, nl);
      buffer_.erase(0, nl + 1);
      return line;
    }
    const std::int64_t left_ms = (deadline - mono_now_ns()) / 1'000'000;
    if (left_ms < 0) return std::nullopt;
    pollfd p{fd_, POLLIN, 0};
    const int r = poll(&p, 1, static_cast<int>(left_ms));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) {
      if (r == 0) return std::nullopt;
      throw std::runtime_error(address_ + ": poll failed");
    }
    char buf[65536];
    const ssize_t n = read(fd_, buf, sizeof(buf));
    if (n == 0) throw std::runtime_error(address_ + ": connection closed by the daemon");
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      throw std::runtime_error(address_ + ": read failed: " + std::strerror(errno));
    }
    buffer_.append(buf, static_cast<std::size_t>(n));
  }
}

nlohmann::json DaemonClient::request(const nlohmann::json& req, results::MessageClass reply_class,
                                     std::chrono::milliseconds timeout) {
  send(req);
  const std::int64_t deadline = mono_now_ns() + timeout.count() * 1'000'000;
  for (;;) {
    const std::int64_t left_ms = (deadline - mono_now_ns()) / 1'000'000;
    if (left_ms < 0) break;
    auto line = read_line(std::chrono::milliseconds(left_ms));
    if (!line) break;
    nlohmann::json j = nlohmann::json::parse(*line, nullptr, false);
    if (j.is_discarded()) continue;
    if (results::has_class(j, reply_class) || results::has_class(j, results::MessageClass::error)) return j;
  }
  throw std::runtime_error(address_ + ": no " + std::string(results::to_string(reply_class)) + " reply within " +
                           std::to_string(timeout.count()) + " ms");
}

DaemonClient connect_daemon(const std::string& address) {
  if (!address.empty()) return DaemonClient(address);
  return DaemonClient::connect_first(client_socket_candidates());
}

void throw_if_error(const nlohmann::json& reply) {
  if (results::has_class(reply, results::MessageClass::error))
    throw std::runtime_error("daemon: " + reply.value("message", "error"));
}

}  // namespace guideway::cli
