#include "cli/daemon_client.hpp"

#include "core/runtime_paths.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "core/mono_clock.hpp"

namespace guideway::cli {

namespace {

int connect_unix(const std::string& path) {
  sockaddr_un addr{};
  if (path.size() >= sizeof(addr.sun_path)) throw std::runtime_error(path + ": socket path too long");
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    const int err = errno;
    close(fd);
    throw std::runtime_error(path + ": " + std::strerror(err));
  }
  return fd;
}

int connect_tcp(const std::string& host_port) {
  const auto colon = host_port.rfind(':');
  if (colon == std::string::npos) throw std::runtime_error("tcp:" + host_port + ": expected tcp:HOST:PORT");
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(std::stoi(host_port.substr(colon + 1))));
  if (inet_pton(AF_INET, host_port.substr(0, colon).c_str(), &addr.sin_addr) != 1) {
    throw std::runtime_error("tcp:" + host_port + ": not an IPv4 address");
  }
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    const int err = errno;
    close(fd);
    throw std::runtime_error("tcp:" + host_port + ": " + std::strerror(err));
  }
  return fd;
}

}  // namespace

DaemonClient::DaemonClient(const std::string& address) : address_(address) {
  fd_ = address.rfind("tcp:", 0) == 0 ? connect_tcp(address.substr(4)) : connect_unix(address);
  auto line = read_line(std::chrono::seconds(5));
  if (!line) throw std::runtime_error(address + ": no VERSION banner from the daemon");
  banner_ = nlohmann::json::parse(*line, nullptr, false);
  if (banner_.is_discarded() || banner_.value("class", "") != "VERSION") {
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

nlohmann::json DaemonClient::request(const nlohmann::json& req, const std::string& reply_class,
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
    const std::string cls = j.value("class", "");
    if (cls == reply_class || cls == "ERROR") return j;
  }
  throw std::runtime_error(address_ + ": no " + reply_class + " reply within " + std::to_string(timeout.count()) + " ms");
}

DaemonClient connect_daemon(const std::string& address) {
  if (!address.empty()) return DaemonClient(address);
  return DaemonClient::connect_first(client_socket_candidates());
}

void throw_if_error(const nlohmann::json& reply) {
  if (reply.value("class", "") == "ERROR") throw std::runtime_error("daemon: " + reply.value("message", "error"));
}

}  // namespace guideway::cli
