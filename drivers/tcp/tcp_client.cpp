#include "drivers/tcp/tcp_client.hpp"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>

namespace guideway::drivers::tcp {

TcpClient::TcpClient() : wake_fd_(eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK)) {}

TcpClient::~TcpClient() {
  close();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

void TcpClient::interrupt() noexcept {
  const std::uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof(one));
}

void TcpClient::clear_interrupt() noexcept {
  std::uint64_t v = 0;
  [[maybe_unused]] const ssize_t n = ::read(wake_fd_, &v, sizeof(v));
}

void TcpClient::close() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

bool TcpClient::connect(const std::string& host, int port, std::chrono::milliseconds timeout, std::string& error) {
  close();
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* list = nullptr;
  const std::string service = std::to_string(port);
  if (const int rc = getaddrinfo(host.c_str(), service.c_str(), &hints, &list); rc != 0) {
    error = host + ": " + gai_strerror(rc);
    return false;
  }
  error = host + ":" + service + ": no address";
  for (addrinfo* ai = list; ai; ai = ai->ai_next) {
    const int fd = ::socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, ai->ai_protocol);
    if (fd < 0) continue;
    int rc = ::connect(fd, ai->ai_addr, ai->ai_addrlen);
    if (rc != 0 && errno == EINPROGRESS) {
      pollfd p[2] = {{fd, POLLOUT, 0}, {wake_fd_, POLLIN, 0}};
      rc = ::poll(p, 2, static_cast<int>(timeout.count()));
      if (rc > 0 && (p[1].revents & POLLIN)) {
        ::close(fd);
        error = "interrupted";
        freeaddrinfo(list);
        return false;
      }
      int so_error = ETIMEDOUT;
      socklen_t len = sizeof(so_error);
      if (rc > 0) getsockopt(fd, SOL_SOCKET, SO_ERROR, &so_error, &len);
      errno = so_error;
      rc = so_error == 0 ? 0 : -1;
    }
    if (rc == 0) {
      const int one = 1;
      setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
      fd_ = fd;
      freeaddrinfo(list);
      return true;
    }
    error = host + ":" + service + ": " + std::strerror(errno);
    ::close(fd);
  }
  freeaddrinfo(list);
  return false;
}

ReadResult TcpClient::read_some(char* buffer, std::size_t size, std::chrono::milliseconds timeout) noexcept {
  if (fd_ < 0) return {ReadStatus::closed, 0, "not connected"};
  pollfd p[2] = {{fd_, POLLIN, 0}, {wake_fd_, POLLIN, 0}};
  int rc;
  do {
    rc = ::poll(p, 2, static_cast<int>(timeout.count()));
  } while (rc < 0 && errno == EINTR);
  if (rc < 0) return {ReadStatus::error, 0, std::strerror(errno)};
  if (rc == 0) return {ReadStatus::timeout, 0, {}};
  if (p[1].revents & POLLIN) return {ReadStatus::interrupted, 0, {}};
  const ssize_t n = ::recv(fd_, buffer, size, 0);
  if (n > 0) return {ReadStatus::data, static_cast<std::size_t>(n), {}};
  if (n == 0) return {ReadStatus::closed, 0, "connection closed by the instrument"};
  if (errno == EAGAIN || errno == EINTR) return {ReadStatus::data, 0, {}};
  return {ReadStatus::closed, 0, std::strerror(errno)};
}

}  // namespace guideway::drivers::tcp
