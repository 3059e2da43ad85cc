// The serial line: the termios backend on a real pseudo-terminal (framing applied, bytes both ways,
// hang-up seen as "closed"), the automatic backend choosing termios for ptys, libserialport's
// refusal of ptys (the platform fact the design works around), and port discovery.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include "drivers/serial/serial_port.hpp"
#include "test_support.hpp"

using namespace guideway::drivers::serial;

namespace {

struct Pty {
  Pty() {
    master = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (master < 0 || ::grantpt(master) < 0 || ::unlockpt(master) < 0) throw std::runtime_error("pty");
    char name[128];
    ::ptsname_r(master, name, sizeof name);
    path = name;
  }
  ~Pty() {
    if (master >= 0) ::close(master);
  }
  int master = -1;
  std::string path;
};

std::string read_for(SerialLine& line, std::size_t want) {
  std::string got;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (got.size() < want && std::chrono::steady_clock::now() < deadline) {
    if (wait_readable(line, 100, -1) != WaitResult::readable) continue;
    char buf[64];
    std::size_t n = 0;
    std::string err;
    if (line.read_some(buf, sizeof buf, n, err) == IoStatus::ok) got.append(buf, n);
  }
  return got;
}

}  // namespace

TEST(SerialPort, FramingParses) {
  SerialSettings s;
  ASSERT_TRUE(parse_framing("7E2", s));
  EXPECT_EQ(s.data_bits, 7);
  EXPECT_EQ(s.parity, 'E');
  EXPECT_EQ(s.stop_bits, 2);
  EXPECT_EQ(framing_string(s), "7E2");
  EXPECT_TRUE(parse_framing("8o1", s));
  EXPECT_EQ(s.parity, 'O');
  EXPECT_FALSE(parse_framing("9N1", s));
  EXPECT_FALSE(parse_framing("8X1", s));
  EXPECT_FALSE(parse_framing("8N3", s));
  EXPECT_FALSE(parse_framing("8N", s));
  EXPECT_TRUE(is_supported_baud_rate(115200));
  EXPECT_FALSE(is_supported_baud_rate(12345));
}

TEST(SerialPort, TermiosBackendConfiguresAPtyAndMovesBytesBothWays) {
  Pty pty;
  SerialSettings s;
  s.port = pty.path;
  s.baud_rate = 19200;
  ASSERT_TRUE(parse_framing("7E2", s));
  std::string err;
  auto line = open_serial(s, err);
  ASSERT_TRUE(line) << err;
  EXPECT_EQ(line->backend(), Backend::termios) << "automatic picks termios for a pty";
  termios tio{};
  ASSERT_EQ(::tcgetattr(line->fd(), &tio), 0);
  EXPECT_EQ(::cfgetospeed(&tio), static_cast<speed_t>(B19200));
  // (A Linux pty forces CS8 without parity whatever is asked, so data bits and parity are not
  // observable here; stop bits and speed are kept.)
  EXPECT_TRUE(tio.c_cflag & CSTOPB);
  EXPECT_FALSE(tio.c_cflag & CRTSCTS);
  EXPECT_FALSE(tio.c_lflag & ECHO);
  EXPECT_FALSE(tio.c_lflag & ICANON);

  ASSERT_EQ(line->write_all("a\r", 500, err), IoStatus::ok) << err;
  char buf[8] = {};
  ssize_t n = 0;
  for (int i = 0; i < 100 && n <= 0; ++i) {
    n = ::read(pty.master, buf, sizeof buf);
    if (n <= 0) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(std::string(buf, static_cast<std::size_t>(n > 0 ? n : 0)), "a\r");
  const std::string reply = "4 003 +1.00 -2.00\r";
  ASSERT_EQ(::write(pty.master, reply.data(), reply.size()), static_cast<ssize_t>(reply.size()));
  EXPECT_EQ(read_for(*line, reply.size()), reply);

  // Unplugged: the master goes away and the line reports it as closed.
  ::close(pty.master);
  pty.master = -1;
  std::size_t got = 0;
  IoStatus st = IoStatus::would_block;
  for (int i = 0; i < 100 && st == IoStatus::would_block; ++i) {
    wait_readable(*line, 20, -1);
    st = line->read_some(buf, sizeof buf, got, err);
  }
  EXPECT_EQ(st, IoStatus::closed);
}

TEST(SerialPort, TermiosFollowsASymlinkToAPty) {
  Pty pty;
  guideway::test::TempDir dir;
  const std::string link = dir.file("ttyEMU0");
  std::filesystem::create_symlink(pty.path, link);
  SerialSettings s;
  s.port = link;
  std::string err;
  auto line = open_serial(s, err);
  ASSERT_TRUE(line) << err;
  EXPECT_EQ(line->backend(), Backend::termios);
}

TEST(SerialPort, LibserialportCannotOpenAPtyWhichIsWhyTermiosExists) {
  Pty pty;
  SerialSettings s;
  s.port = pty.path;
  s.backend = Backend::libserialport;
  std::string err;
  auto line = open_serial(s, err);
  if (line) GTEST_SKIP() << "this libserialport opens ptys; the termios backend is then merely an alternative";
  EXPECT_FALSE(err.empty());
}

TEST(SerialPort, MissingPortsAndBadBaudRatesAreErrorsWithReasons) {
  SerialSettings s;
  s.port = "/nonexistent/ttyUSB9";
  std::string err;
  EXPECT_FALSE(open_serial(s, err));
  EXPECT_NE(err.find("/nonexistent/ttyUSB9"), std::string::npos) << err;
  Pty pty;
  s.port = pty.path;
  s.baud_rate = 12345;
  s.backend = Backend::termios;
  EXPECT_FALSE(open_serial(s, err));
  EXPECT_NE(err.find("baud"), std::string::npos) << err;
}

TEST(SerialPort, DiscoveryListsPortsWithoutFailing) {
  std::vector<SerialPortInfo> ports;
  std::string err;
  ASSERT_TRUE(list_serial_ports(ports, err)) << err;
  for (const auto& p : ports) {
    EXPECT_FALSE(p.name.empty());
    EXPECT_FALSE(p.transport.empty());
    if (p.transport == "usb") {
      EXPECT_GE(p.usb_vid, 0);
    }
  }
}
