// CAN frame I/O over any fd carrying whole `struct can_frame` records (can_io.hpp): SocketCAN or a SEQPACKET gateway,
// with kernel times.
#include "drivers/can/can_io.hpp"

#include <fcntl.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>

namespace guideway::drivers::can {

namespace {

std::string errno_text(const char* what, int err) { return std::string(what) + ": " + std::strerror(err); }

// A socket option that is an int flag, turned on.
bool switch_on(int fd, int level, int option, const char* name, std::string& error) {
  const int on = 1;
  if (::setsockopt(fd, level, option, &on, sizeof on) < 0) {
    error = errno_text((std::string("setsockopt(") + name + ")").c_str(), errno);
    return false;
  }
  return true;
}

bool fill_unix_address(const std::string& path, sockaddr_un& addr, std::string& error) {
  std::memset(&addr, 0, sizeof addr);
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof addr.sun_path) {
    error = "unix socket path \"" + path + "\" is empty or too long";
    return false;
  }
  std::memcpy(addr.sun_path, path.data(), path.size());
  return true;
}

}  // namespace

void CanSocket::reset(int fd) noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = fd;
}

bool parse_can_endpoint(std::string_view text, CanEndpoint& out, std::string& error) {
  CanEndpoint e;
  if (text.starts_with("unix:")) {
    e.kind = CanEndpoint::Kind::unix_gateway;
    e.name = std::string(text.substr(5));
  } else if (text.starts_with("can:")) {
    e.name = std::string(text.substr(4));
  } else {
    e.name = std::string(text);
  }
  if (e.name.empty()) {
    error = "empty CAN endpoint (expected can:IFNAME or unix:PATH)";
    return false;
  }
  if (e.kind == CanEndpoint::Kind::socketcan && e.name.size() >= IFNAMSIZ) {
    error = "CAN interface name \"" + e.name + "\" is too long";
    return false;
  }
  out = std::move(e);
  return true;
}

std::string to_string(const CanEndpoint& endpoint) {
  return (endpoint.kind == CanEndpoint::Kind::unix_gateway ? "unix:" : "can:") + endpoint.name;
}

CanSocket open_socketcan(const std::string& ifname, std::string& error, std::span<const can_filter> filters) {
  CanSocket s(::socket(AF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW));
  if (!s.valid()) {
    error = errno_text("socket(AF_CAN)", errno);
    return {};
  }
  ifreq ifr{};
  if (ifname.size() >= sizeof ifr.ifr_name) {
    error = "CAN interface name too long";
    return {};
  }
  std::memcpy(ifr.ifr_name, ifname.data(), ifname.size());
  if (::ioctl(s.fd(), SIOCGIFINDEX, &ifr) < 0) {
    error = errno_text(("interface " + ifname).c_str(), errno);
    return {};
  }
  // Before bind, so no frame is queued unstamped (it would be stamped when read, as if on arrival).
  if (!enable_rx_timestamps(s.fd(), error)) return {};
  std::string ignored;  // without drop reports frames still flow; the loss shows as partial cycles
  (void)enable_rx_drop_count(s.fd(), ignored);
  const can_err_mask_t err_mask = CAN_ERR_MASK;
  if (::setsockopt(s.fd(), SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask) < 0) {
    error = errno_text("setsockopt(CAN_RAW_ERR_FILTER)", errno);
    return {};
  }
  if (!filters.empty() && ::setsockopt(s.fd(), SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
                                      static_cast<socklen_t>(filters.size_bytes())) < 0) {
    error = errno_text("setsockopt(CAN_RAW_FILTER)", errno);
    return {};
  }
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifr.ifr_ifindex;
  if (::bind(s.fd(), reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) {
    error = errno_text(("bind " + ifname).c_str(), errno);
    return {};
  }
  return s;
}

bool socketcan_available(std::string& reason) {
  const int fd = ::socket(AF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    reason = errno_text("socket(AF_CAN)", errno);
    return false;
  }
  ::close(fd);
  return true;
}

CanSocket connect_can_gateway(const std::string& path, std::string& error) {
  sockaddr_un addr{};
  if (!fill_unix_address(path, addr, error)) return {};
  CanSocket s(::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0));
  if (!s.valid()) {
    error = errno_text("socket(AF_UNIX)", errno);
    return {};
  }
  // Before connect: the peer stamps a frame at send time only if we asked by then; a frame sent
  // earlier would be stamped when read, as if on arrival.
  if (!enable_rx_timestamps(s.fd(), error)) return {};
  if (::connect(s.fd(), reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) {
    error = errno_text(("connect " + path).c_str(), errno);
    return {};
  }
  return s;
}

CanSocket listen_can_gateway(const std::string& path, std::string& error) {
  sockaddr_un addr{};
  if (!fill_unix_address(path, addr, error)) return {};
  CanSocket s(::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0));
  if (!s.valid()) {
    error = errno_text("socket(AF_UNIX)", errno);
    return {};
  }
  ::unlink(path.c_str());
  if (::bind(s.fd(), reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0) {
    error = errno_text(("bind " + path).c_str(), errno);
    return {};
  }
  if (::listen(s.fd(), 4) < 0) {
    error = errno_text("listen", errno);
    return {};
  }
  return s;
}

CanSocket open_can_endpoint(const CanEndpoint& endpoint, std::string& error, std::span<const can_filter> filters) {
  if (endpoint.kind == CanEndpoint::Kind::unix_gateway) return connect_can_gateway(endpoint.name, error);
  return open_socketcan(endpoint.name, error, filters);
}

ReadResult read_can_frame(int fd, can_frame& frame, int timeout_ms, int wake_fd, std::string& error) {
  pollfd fds[2] = {{fd, POLLIN, 0}, {wake_fd, POLLIN, 0}};
  const nfds_t n = wake_fd >= 0 ? 2 : 1;
  for (;;) {
    const int r = ::poll(fds, n, timeout_ms);
    if (r < 0) {
      if (errno == EINTR) continue;
      error = errno_text("poll", errno);
      return ReadResult::error;
    }
    if (r == 0) return ReadResult::timeout;
    break;
  }
  if (n == 2 && (fds[1].revents & POLLIN)) return ReadResult::woken;
  if (fds[0].revents & POLLNVAL) {
    error = "poll: invalid descriptor";
    return ReadResult::error;
  }
  // One record: a larger buffer than can_frame so an oversized record is seen as such (MSG_TRUNC).
  alignas(can_frame) unsigned char buf[sizeof(can_frame) + 64];
  bool reset = false;
  for (;;) {
    const ssize_t got = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT | MSG_TRUNC);
    if (got < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) return reset ? ReadResult::closed : ReadResult::timeout;
      if (errno == ECONNRESET && !reset) {
        // The peer closed with our frames unread. The kernel reports that before the frames still
        // queued for us, and only once: read on so nothing received is lost.
        reset = true;
        continue;
      }
      if (errno == ECONNRESET) return ReadResult::closed;
      error = errno_text("recv", errno);
      return ReadResult::error;
    }
    if (got == 0) return ReadResult::closed;  // SEQPACKET: EOF (we never send zero-length records)
    if (static_cast<std::size_t>(got) != sizeof(can_frame)) return ReadResult::truncated;
    std::memcpy(&frame, buf, sizeof frame);
    return ReadResult::frame;
  }
}

ReadResult read_can_frames(int fd, std::span<can_frame> frames, FrameBatch& batch, std::string& error) {
  return read_can_frames(fd, frames, {}, batch, error);
}

ReadResult read_can_frames(int fd, std::span<can_frame> frames, std::span<std::int64_t> rx_realtime_ns,
                           FrameBatch& batch, std::string& error) {
  batch = {};
  constexpr std::size_t max_records = 64;
  const std::size_t want = std::min(frames.size(), max_records);
  if (want == 0) return ReadResult::timeout;
  const bool timed = !rx_realtime_ns.empty();
  if (timed && rx_realtime_ns.size() < want) {
    error = "read_can_frames: fewer timestamp slots than frames";
    return ReadResult::error;
  }
  // Buffers larger than can_frame so an oversized record is seen as such (MSG_TRUNC), as in read_can_frame.
  struct Slot {
    alignas(can_frame) unsigned char data[sizeof(can_frame) + 64];
    alignas(cmsghdr) unsigned char control[CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t)) + 32];
  };
  std::array<Slot, max_records> slots;
  std::array<iovec, max_records> iov{};
  std::array<mmsghdr, max_records> msgs{};
  for (std::size_t i = 0; i < want; ++i) {
    iov[i] = {slots[i].data, sizeof slots[i].data};
    msgs[i].msg_hdr.msg_iov = &iov[i];
    msgs[i].msg_hdr.msg_iovlen = 1;
    if (timed) {
      msgs[i].msg_hdr.msg_control = slots[i].control;
      msgs[i].msg_hdr.msg_controllen = sizeof slots[i].control;
    }
  }
  int got = -1;
  bool reset = false;
  for (;;) {
    got = ::recvmmsg(fd, msgs.data(), static_cast<unsigned>(want), MSG_DONTWAIT, nullptr);
    if (got >= 0) break;
    if (errno == EINTR) continue;
    if (errno == ECONNRESET && !reset) {
      // The peer closed with our frames unread. The kernel reports that before the frames still
      // queued for us, and only once: read on so nothing received is lost.
      reset = true;
      continue;
    }
    if (errno == EAGAIN || errno == EWOULDBLOCK) return reset ? ReadResult::closed : ReadResult::timeout;
    if (errno == ECONNRESET) return ReadResult::closed;
    // recvmmsg has consumed the socket's error: report it (ENODEV, ENETDOWN: the caller reconnects).
    error = errno_text("recvmmsg", errno);
    return ReadResult::error;
  }
  bool eof = got == 0;
  for (int i = 0; i < got; ++i) {
    const mmsghdr& m = msgs[static_cast<std::size_t>(i)];
    if (m.msg_len == 0) {  // SEQPACKET EOF (we never send zero-length records)
      eof = true;
      break;
    }
    if (m.msg_len != sizeof(can_frame) || (m.msg_hdr.msg_flags & MSG_TRUNC)) {
      ++batch.truncated;
      continue;
    }
    if (timed) {
      const std::int64_t t = rx_timestamp_ns(m.msg_hdr);
      rx_realtime_ns[batch.count] = t;
      if (t == no_rx_timestamp) ++batch.untimed;
      batch.kernel_drops = std::max(batch.kernel_drops, rx_drop_count(m.msg_hdr));
    }
    std::memcpy(&frames[batch.count++], slots[static_cast<std::size_t>(i)].data, sizeof(can_frame));
  }
  if (batch.count + batch.truncated > 0) return ReadResult::frame;  // EOF, if any, is seen on the next read
  return eof || reset ? ReadResult::closed : ReadResult::timeout;
}

bool enable_rx_timestamps(int fd, std::string& error) {
  return switch_on(fd, SOL_SOCKET, SO_TIMESTAMPNS, "SO_TIMESTAMPNS", error);
}

std::int64_t rx_timestamp_ns(const msghdr& message) noexcept {
  if (message.msg_control == nullptr || (message.msg_flags & MSG_CTRUNC)) return no_rx_timestamp;
  for (const cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr;
       c = CMSG_NXTHDR(const_cast<msghdr*>(&message), const_cast<cmsghdr*>(c))) {
    if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SCM_TIMESTAMPNS) continue;
    if (c->cmsg_len < CMSG_LEN(sizeof(timespec))) continue;
    timespec ts{};
    std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
  }
  return no_rx_timestamp;
}

bool enable_rx_drop_count(int fd, std::string& error) {
  return switch_on(fd, SOL_SOCKET, SO_RXQ_OVFL, "SO_RXQ_OVFL", error);
}

bool enable_own_frames(int fd, std::string& error) {
  return switch_on(fd, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, "CAN_RAW_RECV_OWN_MSGS", error);
}

std::uint32_t rx_drop_count(const msghdr& message) noexcept {
  if (message.msg_control == nullptr) return 0;
  for (const cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr;
       c = CMSG_NXTHDR(const_cast<msghdr*>(&message), const_cast<cmsghdr*>(c))) {
    if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SO_RXQ_OVFL) continue;
    if (c->cmsg_len < CMSG_LEN(sizeof(std::uint32_t))) continue;
    std::uint32_t drops = 0;
    std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
    return drops;
  }
  return 0;
}

bool write_can_record(int fd, const void* data, std::size_t size, std::string& error) {
  for (;;) {
    const ssize_t put = ::send(fd, data, size, MSG_NOSIGNAL);
    if (put < 0) {
      if (errno == EINTR) continue;
      error = errno_text("send", errno);
      return false;
    }
    if (static_cast<std::size_t>(put) != size) {
      error = "short write of a CAN frame";
      return false;
    }
    return true;
  }
}

bool write_can_frames(int fd, const can_frame* frames, std::size_t count, std::string& error) {
  constexpr std::size_t batch = 64;
  while (count > 0) {
    const std::size_t n = count < batch ? count : batch;
    iovec iov[batch];
    mmsghdr msgs[batch];
    std::memset(msgs, 0, sizeof msgs);
    for (std::size_t i = 0; i < n; ++i) {
      iov[i].iov_base = const_cast<can_frame*>(&frames[i]);
      iov[i].iov_len = sizeof(can_frame);
      msgs[i].msg_hdr.msg_iov = &iov[i];
      msgs[i].msg_hdr.msg_iovlen = 1;
    }
    const int sent = ::sendmmsg(fd, msgs, static_cast<unsigned>(n), MSG_NOSIGNAL);
    if (sent < 0) {
      if (errno == EINTR) continue;
      error = errno_text("sendmmsg", errno);
      return false;
    }
    frames += sent;
    count -= static_cast<std::size_t>(sent);
  }
  return true;
}

bool write_can_frame(int fd, const can_frame& frame, std::string& error) {
  return write_can_record(fd, &frame, sizeof frame, error);
}

WriteResult try_write_can_frame(int fd, const can_frame& frame, std::string& error) {
  for (;;) {
    const ssize_t put = ::send(fd, &frame, sizeof frame, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (put == static_cast<ssize_t>(sizeof frame)) return WriteResult::written;
    if (put < 0 && errno == EINTR) continue;
    // SocketCAN answers a full transmit queue with ENOBUFS, a socket buffer with EAGAIN.
    if (put < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS)) return WriteResult::queue_full;
    error = put < 0 ? errno_text("send", errno) : "short write of a CAN frame";
    return WriteResult::failed;
  }
}

}  // namespace guideway::drivers::can
