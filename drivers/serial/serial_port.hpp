#pragma once
// One serial-line interface with two backends: libserialport for real ports (and port discovery
// with USB VID/PID/serial number), termios for pseudo-terminals, which libserialport 0.1.1 cannot
// open (no sysfs entry for /dev/pts/N; TIOCMGET fails with ENOTTY). A SerialLine is owned by one
// thread. Nothing here prints or throws: errors go back to the caller as text.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace guideway::drivers::serial {

enum class Backend { automatic, termios, libserialport };
std::string_view to_string(Backend backend) noexcept;

struct SerialSettings {
  std::string port;  // /dev/ttyUSB0, /dev/serial/by-id/..., /dev/pts/7 or a symlink to one
  int baud_rate = 9600;
  int data_bits = 8;                     // 5..8
  char parity = 'N';                     // 'N', 'E', 'O'
  int stop_bits = 1;                     // 1 or 2
  Backend backend = Backend::automatic;  // automatic: termios for pseudo-terminals, else libserialport
};

// Parses framing like "8N1", "7E2"; false when malformed.
bool parse_framing(std::string_view text, SerialSettings& settings);
std::string framing_string(const SerialSettings& settings);
// True for baud rates both backends can set.
bool is_supported_baud_rate(int baud_rate) noexcept;

enum class IoStatus { ok, would_block, closed, error };

class SerialLine {
 public:
  virtual ~SerialLine() = default;
  [[nodiscard]] virtual int fd() const noexcept = 0;  // readable when bytes arrive (for poll)
  // Reads what is available without blocking (got = 0 and would_block when nothing is).
  virtual IoStatus read_some(char* buf, std::size_t size, std::size_t& got, std::string& error) = 0;
  // Writes all of `data` within timeout_ms.
  virtual IoStatus write_all(std::string_view data, int timeout_ms, std::string& error) = 0;
  // Writes what the line takes now, never waiting (written = 0 and would_block when it takes nothing).
  virtual IoStatus write_some(std::string_view data, std::size_t& written, std::string& error) = 0;
  // Discards unread input and unsent output.
  virtual void flush() noexcept = 0;
  [[nodiscard]] virtual Backend backend() const noexcept = 0;
};

// Opens and configures the port (raw mode, no flow control). nullptr with `error` on failure.
std::unique_ptr<SerialLine> open_serial(const SerialSettings& settings, std::string& error);

enum class WaitResult { readable, timeout, woken, error };
// Waits up to timeout_ms for input on the line or for wake_fd (-1: none) to become readable.
WaitResult wait_readable(const SerialLine& line, int timeout_ms, int wake_fd);

// Splits a byte stream into lines. CR, LF and CRLF end a line; empty lines are skipped; a line
// longer than max_line is discarded up to its terminator and counted as an overflow. Not thread safe.
class LineFramer {
 public:
  explicit LineFramer(std::size_t max_line = 256) : max_line_(max_line) {}
  // Appends every completed line to `lines`; returns the number of overflows in this chunk.
  std::size_t feed(std::string_view bytes, std::vector<std::string>& lines);
  void reset() noexcept {
    partial_.clear();
    overflow_ = false;
  }
  [[nodiscard]] std::size_t pending() const noexcept { return partial_.size(); }

 private:
  std::size_t max_line_;
  std::string partial_;
  bool overflow_ = false;
};

// A serial port as the system enumerates it (libserialport).
struct SerialPortInfo {
  std::string name;         // /dev/ttyUSB0
  std::string description;  // e.g. "FT232R USB UART - FT232R USB UART"
  std::string transport;    // "usb", "native", "bluetooth", "unknown"
  int usb_vid = -1;
  int usb_pid = -1;
  int usb_bus = -1;
  int usb_address = -1;
  std::string usb_manufacturer;
  std::string usb_product;
  std::string usb_serial;
};
// Lists the ports; false with `error` when enumeration itself fails (an empty list is not an error).
bool list_serial_ports(std::vector<SerialPortInfo>& ports, std::string& error);

}  // namespace guideway::drivers::serial
