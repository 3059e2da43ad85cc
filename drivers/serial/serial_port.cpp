// One serial-line interface (serial_port.hpp): libserialport for real ports and their discovery, termios for pseudo-
// terminals.
#include "drivers/serial/serial_port.hpp"

#include <fcntl.h>
#include <libserialport.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>

namespace guideway::drivers::serial {

namespace {

std::string errno_text(const std::string& what, int err) { return what + ": " + std::strerror(err); }

struct BaudEntry {
  int baud;
  speed_t speed;
};
constexpr BaudEntry baud_table[] = {
    {1200, B1200},   {2400, B2400},     {4800, B4800},     {9600, B9600},     {19200, B19200},   {38400, B38400},
    {57600, B57600}, {115200, B115200}, {230400, B230400}, {460800, B460800}, {921600, B921600},
};

// termios backend: any tty, in particular pseudo-terminals.
class TermiosLine final : public SerialLine {
 public:
  explicit TermiosLine(int fd) : fd_(fd) {}
  ~TermiosLine() override { ::close(fd_); }
  int fd() const noexcept override { return fd_; }
  IoStatus read_some(char* buf, std::size_t size, std::size_t& got, std::string& error) override {
    got = 0;
    for (;;) {
      const ssize_t n = ::read(fd_, buf, size);
      if (n > 0) {
        got = static_cast<std::size_t>(n);
        return IoStatus::ok;
      }
      if (n == 0) {
        // Raw mode (VMIN = VTIME = 0) reads 0 bytes when none are queued, O_NONBLOCK or not: only a
        // hang-up makes it the end of the line.
        pollfd p{fd_, POLLIN, 0};
        if (::poll(&p, 1, 0) > 0 && (p.revents & (POLLHUP | POLLERR))) return IoStatus::closed;
        return IoStatus::would_block;
      }
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) return IoStatus::would_block;
      if (errno == EIO) return IoStatus::closed;  // pty master gone / device unplugged
      error = errno_text("read", errno);
      return IoStatus::error;
    }
  }
  IoStatus write_all(std::string_view data, int timeout_ms, std::string& error) override {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (!data.empty()) {
      const ssize_t n = ::write(fd_, data.data(), data.size());
      if (n > 0) {
        data.remove_prefix(static_cast<std::size_t>(n));
        continue;
      }
      if (n < 0 && errno == EINTR) continue;
      if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
        if (errno == EIO) return IoStatus::closed;
        error = errno_text("write", errno);
        return IoStatus::error;
      }
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) {
        error = "write timed out";
        return IoStatus::error;
      }
      pollfd p{fd_, POLLOUT, 0};
      ::poll(&p, 1, static_cast<int>(left.count()));
    }
    return IoStatus::ok;
  }
  IoStatus write_some(std::string_view data, std::size_t& written, std::string& error) override {
    written = 0;
    for (;;) {
      const ssize_t n = ::write(fd_, data.data(), data.size());
      if (n >= 0) {
        written = static_cast<std::size_t>(n);
        return n > 0 || data.empty() ? IoStatus::ok : IoStatus::would_block;
      }
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) return IoStatus::would_block;
      if (errno == EIO) return IoStatus::closed;
      error = errno_text("write", errno);
      return IoStatus::error;
    }
  }
  void flush() noexcept override { ::tcflush(fd_, TCIOFLUSH); }
  Backend backend() const noexcept override { return Backend::termios; }

 private:
  int fd_;
};

std::unique_ptr<SerialLine> open_termios(const SerialSettings& s, std::string& error) {
  const int fd = ::open(s.port.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    error = errno_text("open " + s.port, errno);
    return nullptr;
  }
  auto line = std::make_unique<TermiosLine>(fd);
  termios tio{};
  if (::tcgetattr(fd, &tio) < 0) {
    error = errno_text("tcgetattr " + s.port, errno);
    return nullptr;
  }
  ::cfmakeraw(&tio);
  speed_t speed = B9600;
  bool found = false;
  for (const auto& e : baud_table) {
    if (e.baud == s.baud_rate) {
      speed = e.speed;
      found = true;
    }
  }
  if (!found) {
    error = "unsupported baud rate " + std::to_string(s.baud_rate);
    return nullptr;
  }
  ::cfsetispeed(&tio, speed);
  ::cfsetospeed(&tio, speed);
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | PARODD | CSTOPB | CRTSCTS);
  tio.c_cflag |= CLOCAL | CREAD;
  switch (s.data_bits) {
    case 5:
      tio.c_cflag |= CS5;
      break;
    case 6:
      tio.c_cflag |= CS6;
      break;
    case 7:
      tio.c_cflag |= CS7;
      break;
    default:
      tio.c_cflag |= CS8;
      break;
  }
  if (s.parity == 'E') tio.c_cflag |= PARENB;
  if (s.parity == 'O') tio.c_cflag |= PARENB | PARODD;
  if (s.stop_bits == 2) tio.c_cflag |= CSTOPB;
  tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  if (::tcsetattr(fd, TCSANOW, &tio) < 0) {
    error = errno_text("tcsetattr " + s.port, errno);
    return nullptr;
  }
  ::tcflush(fd, TCIOFLUSH);
  return line;
}

std::string sp_error_text(const std::string& what, sp_return r) {
  if (r == SP_ERR_FAIL) {
    char* msg = sp_last_error_message();
    std::string text = what + ": " + (msg ? msg : "failed");
    sp_free_error_message(msg);
    return text;
  }
  if (r == SP_ERR_ARG) return what + ": invalid argument";
  if (r == SP_ERR_MEM) return what + ": out of memory";
  if (r == SP_ERR_SUPP) return what + ": not supported";
  return what + ": error " + std::to_string(static_cast<int>(r));
}

// libserialport backend: real serial ports.
class SpLine final : public SerialLine {
 public:
  explicit SpLine(sp_port* port) : port_(port) {}
  ~SpLine() override {
    sp_close(port_);
    sp_free_port(port_);
  }
  int fd() const noexcept override {
    int fd = -1;
    sp_get_port_handle(port_, &fd);
    return fd;
  }
  IoStatus read_some(char* buf, std::size_t size, std::size_t& got, std::string& error) override {
    got = 0;
    const sp_return r = sp_nonblocking_read(port_, buf, size);
    if (r < 0) {
      error = sp_error_text("read", r);
      return IoStatus::error;
    }
    if (r == 0) {
      // poll said readable but nothing came: the device went away (hangup).
      pollfd p{fd(), POLLIN, 0};
      if (::poll(&p, 1, 0) > 0 && (p.revents & (POLLHUP | POLLERR))) return IoStatus::closed;
      return IoStatus::would_block;
    }
    got = static_cast<std::size_t>(r);
    return IoStatus::ok;
  }
  IoStatus write_all(std::string_view data, int timeout_ms, std::string& error) override {
    const sp_return r = sp_blocking_write(port_, data.data(), data.size(), static_cast<unsigned>(timeout_ms));
    if (r < 0) {
      error = sp_error_text("write", r);
      return IoStatus::error;
    }
    if (static_cast<std::size_t>(r) != data.size()) {
      error = "write timed out";
      return IoStatus::error;
    }
    return IoStatus::ok;
  }
  IoStatus write_some(std::string_view data, std::size_t& written, std::string& error) override {
    written = 0;
    const sp_return r = sp_nonblocking_write(port_, data.data(), data.size());
    if (r < 0) {
      error = sp_error_text("write", r);
      return IoStatus::error;
    }
    written = static_cast<std::size_t>(r);
    return r > 0 || data.empty() ? IoStatus::ok : IoStatus::would_block;
  }
  void flush() noexcept override { sp_flush(port_, SP_BUF_BOTH); }
  Backend backend() const noexcept override { return Backend::libserialport; }

 private:
  sp_port* port_;
};

std::unique_ptr<SerialLine> open_libserialport(const SerialSettings& s, std::string& error) {
  sp_port* port = nullptr;
  sp_return r = sp_get_port_by_name(s.port.c_str(), &port);
  if (r != SP_OK) {
    error = sp_error_text(s.port, r);
    return nullptr;
  }
  r = sp_open(port, SP_MODE_READ_WRITE);
  if (r != SP_OK) {
    error = sp_error_text("open " + s.port, r);
    sp_free_port(port);
    return nullptr;
  }
  auto line = std::make_unique<SpLine>(port);
  const sp_parity parity = s.parity == 'E' ? SP_PARITY_EVEN : s.parity == 'O' ? SP_PARITY_ODD : SP_PARITY_NONE;
  if ((r = sp_set_baudrate(port, s.baud_rate)) != SP_OK || (r = sp_set_bits(port, s.data_bits)) != SP_OK ||
      (r = sp_set_parity(port, parity)) != SP_OK || (r = sp_set_stopbits(port, s.stop_bits)) != SP_OK ||
      (r = sp_set_flowcontrol(port, SP_FLOWCONTROL_NONE)) != SP_OK) {
    error = sp_error_text("configure " + s.port, r);
    return nullptr;
  }
  sp_flush(port, SP_BUF_BOTH);
  return line;
}

bool is_pseudo_terminal(const std::string& port) {
  std::error_code ec;
  const auto real = std::filesystem::canonical(port, ec);
  return !ec && real.string().starts_with("/dev/pts/");
}

}  // namespace

std::string_view to_string(Backend backend) noexcept {
  switch (backend) {
    case Backend::automatic:
      return "auto";
    case Backend::termios:
      return "termios";
    case Backend::libserialport:
      return "libserialport";
  }
  return "?";
}

bool parse_framing(std::string_view text, SerialSettings& s) {
  if (text.size() != 3) return false;
  if (text[0] < '5' || text[0] > '8') return false;
  const char p = static_cast<char>(text[1] >= 'a' ? text[1] - 'a' + 'A' : text[1]);
  if (p != 'N' && p != 'E' && p != 'O') return false;
  if (text[2] != '1' && text[2] != '2') return false;
  s.data_bits = text[0] - '0';
  s.parity = p;
  s.stop_bits = text[2] - '0';
  return true;
}

std::string framing_string(const SerialSettings& s) {
  return std::to_string(s.data_bits) + s.parity + std::to_string(s.stop_bits);
}

bool is_supported_baud_rate(int baud_rate) noexcept {
  for (const auto& e : baud_table) {
    if (e.baud == baud_rate) return true;
  }
  return false;
}

std::unique_ptr<SerialLine> open_serial(const SerialSettings& s, std::string& error) {
  switch (s.backend) {
    case Backend::termios:
      return open_termios(s, error);
    case Backend::libserialport:
      return open_libserialport(s, error);
    case Backend::automatic:
      break;
  }
  std::error_code ec;
  // Pseudo-terminals, and paths that do not exist (the clearest error comes from open()).
  if (is_pseudo_terminal(s.port) || !std::filesystem::exists(s.port, ec)) return open_termios(s, error);
  std::string sp_error;
  auto line = open_libserialport(s, sp_error);
  if (line) return line;
  // No sysfs entry (not a port libserialport knows, e.g. a pty we could not resolve): try termios.
  auto fallback = open_termios(s, error);
  if (!fallback) error = sp_error + "; termios: " + error;
  return fallback;
}

WaitResult wait_readable(const SerialLine& line, int timeout_ms, int wake_fd) {
  pollfd fds[2] = {{line.fd(), POLLIN, 0}, {wake_fd, POLLIN, 0}};
  for (;;) {
    const int r = ::poll(fds, wake_fd >= 0 ? 2 : 1, timeout_ms);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) return WaitResult::error;
    if (r == 0) return WaitResult::timeout;
    if (wake_fd >= 0 && (fds[1].revents & POLLIN)) return WaitResult::woken;
    return WaitResult::readable;  // POLLIN, POLLHUP or POLLERR: the read says which
  }
}

std::size_t LineFramer::feed(std::string_view bytes, std::vector<std::string>& lines) {
  std::size_t overflows = 0;
  for (const char c : bytes) {
    if (c == '\r' || c == '\n') {
      if (!overflow_ && !partial_.empty()) lines.push_back(partial_);
      partial_.clear();
      overflow_ = false;
      continue;
    }
    if (overflow_) continue;
    if (partial_.size() >= max_line_) {
      overflow_ = true;
      ++overflows;
      partial_.clear();
      continue;
    }
    partial_.push_back(c);
  }
  return overflows;
}

bool list_serial_ports(std::vector<SerialPortInfo>& ports, std::string& error) {
  ports.clear();
  sp_port** list = nullptr;
  const sp_return r = sp_list_ports(&list);
  if (r != SP_OK) {
    error = sp_error_text("list ports", r);
    return false;
  }
  for (sp_port** p = list; *p; ++p) {
    SerialPortInfo info;
    const char* name = sp_get_port_name(*p);
    const char* desc = sp_get_port_description(*p);
    info.name = name ? name : "";
    info.description = desc ? desc : "";
    switch (sp_get_port_transport(*p)) {
      case SP_TRANSPORT_USB: {
        info.transport = "usb";
        int vid = -1, pid = -1, bus = -1, addr = -1;
        if (sp_get_port_usb_vid_pid(*p, &vid, &pid) == SP_OK) {
          info.usb_vid = vid;
          info.usb_pid = pid;
        }
        if (sp_get_port_usb_bus_address(*p, &bus, &addr) == SP_OK) {
          info.usb_bus = bus;
          info.usb_address = addr;
        }
        const char* m = sp_get_port_usb_manufacturer(*p);
        const char* pr = sp_get_port_usb_product(*p);
        const char* sn = sp_get_port_usb_serial(*p);
        info.usb_manufacturer = m ? m : "";
        info.usb_product = pr ? pr : "";
        info.usb_serial = sn ? sn : "";
        break;
      }
      case SP_TRANSPORT_BLUETOOTH:
        info.transport = "bluetooth";
        break;
      case SP_TRANSPORT_NATIVE:
        info.transport = "native";
        break;
      default:
        info.transport = "unknown";
        break;
    }
    ports.push_back(std::move(info));
  }
  sp_free_port_list(list);
  return true;
}

}  // namespace guideway::drivers::serial
