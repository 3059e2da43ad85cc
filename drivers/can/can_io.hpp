#pragma once
// CAN frame I/O over any file descriptor that carries whole `struct can_frame` records: a SocketCAN
// raw socket (AF_CAN), or an AF_UNIX SOCK_SEQPACKET socket (socketpair, or the Unix "CAN gateway"
// socket the emulator serves, for kernels without AF_CAN). Free functions are thread safe; a
// CanSocket is owned by one thread. Nothing here prints or throws: errors go back to the caller.

#include <linux/can.h>
#include <sys/socket.h>

#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace guideway::drivers::can {

// An owned file descriptor (closed on destruction). Move-only.
class CanSocket {
 public:
  CanSocket() = default;
  explicit CanSocket(int fd) noexcept : fd_(fd) {}
  ~CanSocket() { reset(); }
  CanSocket(CanSocket&& o) noexcept : fd_(o.release()) {}
  CanSocket& operator=(CanSocket&& o) noexcept {
    if (this != &o) reset(o.release());
    return *this;
  }
  CanSocket(const CanSocket&) = delete;
  CanSocket& operator=(const CanSocket&) = delete;

  [[nodiscard]] int fd() const noexcept { return fd_; }
  [[nodiscard]] bool valid() const noexcept { return fd_ >= 0; }
  int release() noexcept {
    const int fd = fd_;
    fd_ = -1;
    return fd;
  }
  void reset(int fd = -1) noexcept;

 private:
  int fd_ = -1;
};

// Where a CAN bus is reached. `can:IFNAME` (or a bare interface name) is a SocketCAN interface;
// `unix:PATH` is a SOCK_SEQPACKET Unix socket carrying can_frame records (the emulator's gateway).
struct CanEndpoint {
  enum class Kind { socketcan, unix_gateway };
  Kind kind = Kind::socketcan;
  std::string name;  // interface name or socket path
};
// Parses "can:vcan0", "vcan0", "unix:/run/x.sock"; returns false with a reason on an empty name.
bool parse_can_endpoint(std::string_view text, CanEndpoint& out, std::string& error);
std::string to_string(const CanEndpoint& endpoint);

// Opens a raw SocketCAN socket bound to `ifname` with error frames and receive timestamps enabled. Returns an invalid
// socket and sets `error` (e.g. "socket(AF_CAN): Address family not supported by protocol").
// `filters` (CAN_RAW_FILTER), if any, are installed before bind: only matching data frames (and error
// frames) are received, so other traffic on the bus never wakes the reader. Empty: every frame.
CanSocket open_socketcan(const std::string& ifname, std::string& error, std::span<const can_filter> filters = {});
// True when this kernel supports AF_CAN sockets; otherwise `reason` says why (errno text).
bool socketcan_available(std::string& reason);

// Connects to a Unix SOCK_SEQPACKET CAN gateway at `path`, receive timestamps enabled.
CanSocket connect_can_gateway(const std::string& path, std::string& error);
// Listens on a Unix SOCK_SEQPACKET socket at `path` (an existing socket file is replaced).
CanSocket listen_can_gateway(const std::string& path, std::string& error);

// `filters` apply to SocketCAN only (a Unix gateway carries one device's traffic).
CanSocket open_can_endpoint(const CanEndpoint& endpoint, std::string& error,
                            std::span<const can_filter> filters = {});

enum class ReadResult {
  frame,      // one complete frame in `frame`
  timeout,    // nothing within the timeout
  woken,      // the wake fd became readable (the caller is being stopped)
  truncated,  // a record shorter than struct can_frame (the bytes are discarded)
  closed,     // the peer closed the connection (EOF)
  error,      // read/poll failed; errno text in `error`
};

// Waits up to timeout_ms (-1: forever) for one frame on fd, or for wake_fd (-1: none) to become
// readable. Records longer than can_frame (CAN FD) are reported as truncated too.
ReadResult read_can_frame(int fd, can_frame& frame, int timeout_ms, int wake_fd, std::string& error);

// Reads every record already queued on fd, up to frames.size(), with one recvmmsg; never waits.
// Whole frames go to frames[0..count) in arrival order; records of another size are discarded and
// counted in `truncated`. Returns frame when any record was read, timeout when none was queued,
// closed at EOF (after every queued frame) and error (errno text in `error`) as read_can_frame.
struct FrameBatch {
  std::size_t count = 0;
  std::size_t truncated = 0;
  std::size_t untimed = 0;  // frames that came without a kernel timestamp (when rx times were asked for)
  // The highest total of frames the kernel dropped on this socket (receive queue full) that the
  // batch's messages reported (see enable_rx_drop_count; when rx times were asked for), 0 if none did.
  std::uint32_t kernel_drops = 0;
};
ReadResult read_can_frames(int fd, std::span<can_frame> frames, FrameBatch& batch, std::string& error);
// The same, and rx_realtime_ns[i] (rx_realtime_ns.size() >= frames.size()) gets frame i's kernel
// receive time (see enable_rx_timestamps), or no_rx_timestamp when its message carried none.
ReadResult read_can_frames(int fd, std::span<can_frame> frames, std::span<std::int64_t> rx_realtime_ns,
                           FrameBatch& batch, std::string& error);

// Asks the kernel to timestamp every frame fd receives (SO_TIMESTAMPNS, CLOCK_REALTIME): SocketCAN
// stamps a frame when the interface receives it, an AF_UNIX socket when the peer sends it. The time
// then comes as an SCM_TIMESTAMPNS control message with each message. False with `error` on failure.
bool enable_rx_timestamps(int fd, std::string& error);
inline constexpr std::int64_t no_rx_timestamp = INT64_MIN;
// The SCM_TIMESTAMPNS time carried by a received message, in CLOCK_REALTIME nanoseconds, or
// no_rx_timestamp when it has none (or its control data was truncated).
std::int64_t rx_timestamp_ns(const msghdr& message) noexcept;

// Asks the kernel to report frames it dropped because fd's receive queue was full (SO_RXQ_OVFL): each
// message queued after a drop carries the socket's total drops so far (SocketCAN). AF_UNIX accepts
// the option and never reports: a full SEQPACKET queue makes the sender wait instead of dropping.
bool enable_rx_drop_count(int fd, std::string& error);
// A SocketCAN socket reads the frames it wrote back, in their place on the bus (CAN_RAW_RECV_OWN_MSGS): a
// SYNC producer's echo orders the PDOs around it. Other sockets refuse it (the emulators' gateway echoes a
// SYNC by itself).
bool enable_own_frames(int fd, std::string& error);
// The socket's total drops carried by a received message (SO_RXQ_OVFL), 0 when it carries none.
std::uint32_t rx_drop_count(const msghdr& message) noexcept;

// Writes one frame; false with `error` on failure (EAGAIN counts as failure: the bus is congested).
bool write_can_frame(int fd, const can_frame& frame, std::string& error);
enum class WriteResult {
  written,
  queue_full,  // the transmit queue is full (SocketCAN: no node acknowledges; gateway: the peer does not read)
  failed,      // the connection is gone; `error` says why
};
// Writes one frame without ever waiting, whether or not fd is non-blocking.
WriteResult try_write_can_frame(int fd, const can_frame& frame, std::string& error);
// Writes several frames with one system call (sendmmsg), so a peer never sees half of a batch
// because the writer was descheduled; false with `error` unless all were written.
bool write_can_frames(int fd, const can_frame* frames, std::size_t count, std::string& error);
// Writes `size` raw bytes as one record (fault injection: truncated frames).
bool write_can_record(int fd, const void* data, std::size_t size, std::string& error);

// The standard (11-bit) identifier of a data frame, without flag bits.
inline std::uint32_t can_std_id(const can_frame& f) noexcept { return f.can_id & CAN_SFF_MASK; }
inline bool is_error_frame(const can_frame& f) noexcept { return (f.can_id & CAN_ERR_FLAG) != 0; }
inline bool is_rtr_frame(const can_frame& f) noexcept { return (f.can_id & CAN_RTR_FLAG) != 0; }
inline bool is_extended_frame(const can_frame& f) noexcept { return (f.can_id & CAN_EFF_FLAG) != 0; }

}  // namespace guideway::drivers::can
