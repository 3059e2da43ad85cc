// TCP for loop-driven drivers (tcp_client.hpp): non-blocking connects and reads that never wait and carry the kernel's
// receive time.
#include "drivers/tcp/tcp_client.hpp"

#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <mutex>
#include <thread>

namespace guideway::drivers::tcp {

struct Resolver::State {
  std::mutex mutex;
  bool done = false;
  std::vector<Address> addresses;
  std::string error;
};

namespace {

void lookup(const std::string& host, int port, bool numeric_only, std::vector<Address>& out, std::string& error) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = numeric_only ? AI_NUMERICHOST | AI_NUMERICSERV : AI_NUMERICSERV;
  addrinfo* list = nullptr;
  const std::string service = std::to_string(port);
  if (const int rc = ::getaddrinfo(host.c_str(), service.c_str(), &hints, &list); rc != 0) {
    error = host + ": " + ::gai_strerror(rc);
    return;
  }
  for (const addrinfo* ai = list; ai != nullptr; ai = ai->ai_next) {
    Address a;
    std::memcpy(&a.storage, ai->ai_addr, ai->ai_addrlen);
    a.length = ai->ai_addrlen;
    out.push_back(a);
  }
  ::freeaddrinfo(list);
  if (out.empty()) error = host + ":" + service + ": no address";
}

}  // namespace

Resolver::Resolver() = default;
Resolver::~Resolver() = default;

void Resolver::start(const std::string& host, int port) {
  state_ = std::make_shared<State>();
  std::vector<Address> numeric;
  std::string error;
  lookup(host, port, true, numeric, error);
  if (!numeric.empty()) {  // an address: no lookup, no thread
    state_->addresses = std::move(numeric);
    state_->done = true;
    return;
  }
  std::thread([state = state_, host, port] {
    std::vector<Address> addresses;
    std::string why;
    lookup(host, port, false, addresses, why);
    std::lock_guard lock(state->mutex);
    state->addresses = std::move(addresses);
    state->error = std::move(why);
    state->done = true;
  }).detach();
}

bool Resolver::done(std::vector<Address>& addresses, std::string& error) {
  if (!state_) return false;
  std::lock_guard lock(state_->mutex);
  if (!state_->done) return false;
  addresses = state_->addresses;
  error = state_->error;
  return true;
}

void Resolver::cancel() noexcept { state_.reset(); }

int start_connect(const Address& address, bool& connected, std::string& error) {
  connected = false;
  const int fd = ::socket(address.storage.ss_family, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, IPPROTO_TCP);
  if (fd < 0) {
    error = std::string("socket: ") + std::strerror(errno);
    return -1;
  }
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address.storage), address.length) == 0) {
    connected = true;
    return fd;
  }
  if (errno == EINPROGRESS) return fd;
  error = std::strerror(errno);
  ::close(fd);
  return -1;
}

int connect_error(int fd) noexcept {
  int so_error = 0;
  socklen_t len = sizeof so_error;
  if (::getsockopt(fd, SOL_SOCKET, SO_ERROR, &so_error, &len) != 0) return errno;
  return so_error;
}

void set_stream_options(int fd) noexcept {
  const int one = 1;
  (void)::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  (void)::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one);
}

ReadResult read_some(int fd, char* buffer, std::size_t size) noexcept {
  iovec iov{buffer, size};
  alignas(cmsghdr) unsigned char control[CMSG_SPACE(sizeof(timespec)) + 32];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  ssize_t n = 0;
  do {
    n = ::recvmsg(fd, &msg, MSG_DONTWAIT);
  } while (n < 0 && errno == EINTR);
  if (n == 0) return {ReadStatus::closed, 0, no_rx_timestamp, "connection closed by the instrument"};
  if (n < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK) return {ReadStatus::would_block, 0, no_rx_timestamp, {}};
    return {ReadStatus::closed, 0, no_rx_timestamp, std::strerror(errno)};
  }
  ReadResult r{ReadStatus::data, static_cast<std::size_t>(n), no_rx_timestamp, {}};
  if ((msg.msg_flags & MSG_CTRUNC) == 0) {
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SCM_TIMESTAMPNS || c->cmsg_len < CMSG_LEN(sizeof(timespec)))
        continue;
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      r.rx_realtime_ns = static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
    }
  }
  return r;
}

}  // namespace guideway::drivers::tcp
