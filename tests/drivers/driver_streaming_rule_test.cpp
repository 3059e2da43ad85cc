// The one rule of `streaming` (Driver::set_sample_bound, set by the driver skeleton for every built-in
// driver): a device is `streaming` only while samples arrive within its bound. Each built-in driver
// against a peer that sends only junk and one that stays silent, on its real transport (TCP on
// loopback, a pseudo-terminal, can_frame records over a socketpair): never `streaming`, `lost` with
// the reason once the bound passed. And a profilometer whose peer turns to junk after a stream of
// points leaves `streaming` within its bound (it said `streaming` forever).
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <pty.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "drivers/autocollimator/autocollimator_driver.hpp"
#include "drivers/dbb/dbb_driver.hpp"
#include "drivers/micrometer/micrometer_driver.hpp"
#include "drivers/profilometer/profile_stream.hpp"
#include "drivers/profilometer/profilometer_driver.hpp"
#include "driver_samples_support.hpp"
#include "test_support.hpp"

using namespace guideway;
using namespace std::chrono_literals;
using drivers::DeviceState;

namespace {

enum class Peer { junk, silent };

// Writes all of `data` unless the peer went (false).
bool send_all(int fd, const std::string& data) {
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::send(fd, data.data() + done, data.size() - done, MSG_NOSIGNAL);
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

// Reads and drops what the driver sent; false once it closed. Waits up to wait_ms for it.
bool discard_input(int fd, int wait_ms) {
  pollfd p{fd, POLLIN, 0};
  if (::poll(&p, 1, wait_ms) <= 0) return true;
  char buf[4096];
  const ssize_t n = ::read(fd, buf, sizeof buf);
  return n > 0 || (n < 0 && errno == EINTR);
}

// A TCP peer on 127.0.0.1: every connection accepted is served by `serve` until it returns or the
// peer stops.
class TcpPeer {
 public:
  using Serve = std::function<void(int fd, const std::atomic<bool>& running)>;
  explicit TcpPeer(Serve serve) : listener_(test::listen_on_loopback(port_)), serve_(std::move(serve)) {
    thread_ = std::thread([this] {
      while (running_) {
        pollfd p{listener_, POLLIN, 0};
        if (::poll(&p, 1, 20) <= 0) continue;
        const int fd = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
        if (fd < 0) continue;
        serve_(fd, running_);
        ::close(fd);
      }
    });
  }
  ~TcpPeer() {
    running_ = false;
    thread_.join();
    ::close(listener_);
  }
  [[nodiscard]] int port() const { return port_; }

 private:
  int port_ = 0;
  int listener_;
  Serve serve_;
  std::atomic<bool> running_{true};
  std::thread thread_;
};

// Sends `line` every 2 ms (junk) or nothing (silent), dropping what the driver sends, until it goes.
void serve(Peer peer, const std::string& line, int fd, const std::atomic<bool>& running) {
  while (running) {
    if (peer == Peer::junk && !send_all(fd, line)) return;
    if (!discard_input(fd, 2)) return;
  }
}

// What a device showed while it was watched every 2 ms.
struct Seen {
  bool streaming = false;
  bool connecting = false;
  bool lost = false;
  std::string lost_reason;
  std::uint64_t bad_frames = 0;
};

Seen watch(const drivers::Driver& d, std::chrono::milliseconds window) {
  Seen seen;
  const auto end = std::chrono::steady_clock::now() + window;
  while (std::chrono::steady_clock::now() < end) {
    const drivers::DriverStatus s = d.status();
    seen.streaming |= s.state == DeviceState::streaming;
    seen.connecting |= s.state == DeviceState::connecting;
    if (s.state == DeviceState::lost && seen.lost_reason.empty()) seen.lost_reason = s.reason;
    seen.lost |= s.state == DeviceState::lost;
    seen.bad_frames = s.counters.bad_frames;
    std::this_thread::sleep_for(2ms);
  }
  return seen;
}

// Never streaming, no sample; lost once the bound passed (the driver's own reason, or the rule's), or
// (expect_lost false: the DBB, whose nodes were never heard from) still connecting, with the reason.
void expect_never_streaming(drivers::Driver& d, Peer peer, std::chrono::milliseconds window, bool expect_lost = true) {
  const Seen seen = watch(d, window);
  EXPECT_FALSE(seen.streaming) << "a peer that sends " << (peer == Peer::junk ? "junk" : "nothing")
                               << " was shown streaming";
  EXPECT_EQ(d.status().counters.samples, 0u);
  const drivers::DriverStatus last = d.status();
  if (expect_lost) {
    EXPECT_TRUE(seen.lost) << "never lost; last state " << drivers::to_string(last.state) << ": " << last.reason;
  } else {
    EXPECT_TRUE(seen.lost || last.state == DeviceState::connecting) << drivers::to_string(last.state);
  }
  EXPECT_FALSE(last.reason.empty());
  if (peer == Peer::junk) {
    EXPECT_GT(seen.bad_frames, 0u);
  }
}

drivers::profilometer::ProfilometerConfig profilometer_config(int port) {
  drivers::profilometer::ProfilometerConfig c;
  c.port = port;
  c.connect_timeout = 200ms;
  c.stall_timeout = 300ms;
  c.reconnect.backoff = Backoff::between(10ms, 50ms);
  return c;
}

}  // namespace

TEST(StreamingRule, ProfilometerJunkOrSilentPeerIsNeverStreaming) {
  for (const Peer peer : {Peer::junk, Peer::silent}) {
    SCOPED_TRACE(peer == Peer::junk ? "junk" : "silent");
    TcpPeer tcp([peer](int fd, const std::atomic<bool>& running) {
      serve(peer, "this is no profile line\n", fd, running);
    });
    drivers::profilometer::ProfilometerDriver d("prof", profilometer_config(tcp.port()), 256);
    d.start();
    expect_never_streaming(d, peer, 700ms);
    d.stop();
  }
}

// The defect of issue 46: points, then only junk: the bytes kept the link alive and the state stayed
// `streaming` with no sample for as long as the junk came.
TEST(StreamingRule, ProfilometerThatTurnsToJunkLeavesStreamingWithinItsBound) {
  using namespace drivers::profilometer;
  std::atomic<bool> junk{false};
  TcpPeer tcp([&junk](int fd, const std::atomic<bool>& running) {
    ProfileHeader h;
    h.id = 1;
    h.points = 1'000'000;
    h.length_m = 1.0;
    h.spacing_m = 1e-6;
    if (!send_all(fd, frame_line(format_banner("test")) + frame_line(format_header(h)))) return;
    for (std::uint64_t i = 0; running; ++i) {
      const std::string line = junk ? std::string("#### junk ####\n") : frame_line(format_point(i, static_cast<double>(i) * 1e-6, 0.0, h));
      if (!send_all(fd, line) || !discard_input(fd, 1)) return;
    }
  });
  ProfilometerConfig c = profilometer_config(tcp.port());
  c.stall_timeout = 400ms;
  ProfilometerDriver d("prof", c, 1 << 14);
  d.start();
  ASSERT_TRUE(test::eventually([&] { return d.status().state == DeviceState::streaming; }, 5s))
      << drivers::to_string(d.status().state) << ": " << d.status().reason;
  junk = true;
  // The points already sent are read within a read period; the bound (400 ms) then passes.
  ASSERT_TRUE(test::eventually([&] { return d.status().state == DeviceState::lost; }, 3s))
      << drivers::to_string(d.status().state) << ": " << d.status().reason;
  const drivers::DriverStatus s = d.status();
  EXPECT_NE(s.reason.find("no sample for more than 400 ms"), std::string::npos) << s.reason;
  EXPECT_NE(s.reason.find("bad frames on this link"), std::string::npos) << s.reason;
  EXPECT_GT(s.counters.bad_frames, 0u);
  d.stop();
}

TEST(StreamingRule, MicrometerOverTcpJunkOrSilentPeerIsNeverStreaming) {
  for (const Peer peer : {Peer::junk, Peer::silent}) {
    SCOPED_TRACE(peer == Peer::junk ? "junk" : "silent");
    TcpPeer tcp([peer](int fd, const std::atomic<bool>& running) {
      serve(peer, std::string("\x00\x07\x00\x00\x00\x05\x01\x04\x02\xde\xad junk", 17), fd, running);
    });
    drivers::micrometer::MicrometerConfig c;
    c.endpoint.kind = drivers::modbus::ModbusEndpoint::Kind::tcp;
    c.endpoint.port = tcp.port();
    c.endpoint.response_timeout = 50ms;
    c.poll_hz = 50.0;
    c.lost_after_failures = 2;
    c.reconnect.backoff = Backoff::between(10ms, 50ms);
    drivers::micrometer::MicrometerDriver d("mic", c, 256);
    d.start();
    expect_never_streaming(d, peer, 700ms);
    d.stop();
  }
}

// A device opening its link again after a loss says where it connects and why the last link ended: a
// status read in that instant once showed a bare `connecting` (this file's junk peer, 1 run in ~30).
// The peer: a listener whose accept queue is full (backlog 0, one connection queued, never accepted),
// where the kernel drops further SYNs, so each attempt stays `connecting` until its timeout.
TEST(StreamingRule, AReconnectingDeviceSaysWhereItConnectsAndWhyTheLastLinkEnded) {
  int port = 0;
  const int listener = test::listen_on_loopback(port);
  ASSERT_EQ(::listen(listener, 0), 0);
  const int queued = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  ASSERT_EQ(::connect(queued, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  drivers::micrometer::MicrometerConfig c;
  c.endpoint.kind = drivers::modbus::ModbusEndpoint::Kind::tcp;
  c.endpoint.port = port;
  c.endpoint.response_timeout = 150ms;
  c.reconnect.backoff = Backoff::between(10ms, 50ms);
  drivers::micrometer::MicrometerDriver d("mic", c, 256);
  const std::string where = "connecting to " + c.endpoint.describe();
  d.start();
  std::string first, again;
  ASSERT_TRUE(test::eventually(
      [&] {
        const drivers::DriverStatus s = d.status();
        if (s.state == DeviceState::connecting && s.reason.rfind(where, 0) == 0) {
          if (s.reason.find("(the last link: ") == std::string::npos) {
            if (first.empty()) first = s.reason;
          } else {
            again = s.reason;
          }
        }
        return !again.empty();
      },
      5s))
      << drivers::to_string(d.status().state) << ": " << d.status().reason;
  EXPECT_EQ(first, where) << "the first attempt, before any link ended";
  EXPECT_NE(again.find(std::to_string(port)), std::string::npos) << again;
  d.stop();
  ::close(queued);
  ::close(listener);
}

// A pseudo-terminal whose far end sends junk lines every 2 ms, or nothing, and drops what it is sent.
struct PtyPeer {
  explicit PtyPeer(Peer peer, std::string line) {
    char name[256] = {};
    if (::openpty(&master, &slave, name, nullptr, nullptr) != 0) throw std::runtime_error("openpty");
    path = name;
    thread = std::thread([this, peer, line = std::move(line)] {
      while (running) {
        if (peer == Peer::junk) (void)!::write(master, line.data(), line.size());
        pollfd p{master, POLLIN, 0};
        if (::poll(&p, 1, 2) > 0) {
          char buf[512];
          (void)!::read(master, buf, sizeof buf);
        }
      }
    });
  }
  ~PtyPeer() {
    running = false;
    thread.join();
    ::close(master);
    ::close(slave);
  }
  int master = -1;
  int slave = -1;  // held open, so the line never hangs up while the driver reopens it
  std::string path;
  std::atomic<bool> running{true};
  std::thread thread;
};

TEST(StreamingRule, AutocollimatorJunkOrSilentPeerIsNeverStreaming) {
  for (const Peer peer : {Peer::junk, Peer::silent}) {
    SCOPED_TRACE(peer == Peer::junk ? "junk" : "silent");
    PtyPeer pty(peer, "?? no reading here ??\r\n");
    drivers::autocollimator::AutocollimatorSettings s;
    s.serial.port = pty.path;
    s.serial.backend = drivers::serial::Backend::termios;
    s.poll_period_ms = 20;
    s.reply_timeout_ms = 50;
    s.lost_after_timeouts = 2;
    s.reconnect.backoff = Backoff::between(std::chrono::milliseconds(10), std::chrono::milliseconds(50));
    drivers::autocollimator::AutocollimatorDriver d("ac", 256, s);
    d.start();
    expect_never_streaming(d, peer, 700ms);
    d.stop();
  }
}

TEST(StreamingRule, MicrometerOverRtuJunkOrSilentPeerIsNeverStreaming) {
  for (const Peer peer : {Peer::junk, Peer::silent}) {
    SCOPED_TRACE(peer == Peer::junk ? "junk" : "silent");
    PtyPeer pty(peer, std::string("\x01\x04\x02\xde\xad\x00\x00 junk", 12));
    drivers::micrometer::MicrometerConfig c;
    c.endpoint.kind = drivers::modbus::ModbusEndpoint::Kind::rtu;
    c.endpoint.device = pty.path;
    c.endpoint.baud = 115200;
    c.endpoint.response_timeout = 50ms;
    c.poll_hz = 50.0;
    c.lost_after_failures = 2;
    c.reconnect.backoff = Backoff::between(10ms, 50ms);
    drivers::micrometer::MicrometerDriver d("mic", c, 256);
    d.start();
    expect_never_streaming(d, peer, 700ms);
    d.stop();
  }
}

TEST(StreamingRule, DbbJunkOrSilentBusIsNeverStreaming) {
  for (const Peer peer : {Peer::junk, Peer::silent}) {
    SCOPED_TRACE(peer == Peer::junk ? "junk" : "silent");
    std::atomic<bool> running{true};
    std::vector<std::thread> bus;  // one per connection
    drivers::dbb::DbbSettings s;
    s.produce_sync = true;
    s.sync_rate_hz = 200.0;
    s.timeout_ms = 100;
    s.reconnect.backoff = Backoff::between(std::chrono::milliseconds(10), std::chrono::milliseconds(50));
    s.network.sdo_checks = false;  // the nodes are started (NMT), never heard from
    s.encoders = {{"bar_length", 1, 1e-7, +1, 0, 0.1}, {"x", 2, 1e-7, +1, 0, 0.0}};
    s.nodes.resize(2);
    drivers::dbb::DbbDriver d("dbb", 256, s, [&](std::string& err) {
      int sv[2];
      if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) < 0) {
        err = "socketpair failed";
        return drivers::can::CanSocket{};
      }
      bus.emplace_back([&running, peer, fd = sv[1]] {
        // Junk: frames of nodes not configured, and our nodes' PDOs one byte short.
        can_frame foreign{};
        foreign.can_id = 0x1F5;
        foreign.can_dlc = 8;
        can_frame short_pdo{};
        short_pdo.can_id = 0x181;
        short_pdo.can_dlc = 3;
        while (running) {
          if (peer == Peer::junk) {
            if (::send(fd, &foreign, sizeof foreign, MSG_NOSIGNAL) < 0) break;
            if (::send(fd, &short_pdo, sizeof short_pdo, MSG_NOSIGNAL) < 0) break;
          }
          if (!discard_input(fd, 2)) break;
        }
        ::close(fd);
      });
      return drivers::can::CanSocket(sv[0]);
    });
    d.start();
    expect_never_streaming(d, peer, 700ms, false);
    d.stop();
    running = false;
    for (std::thread& t : bus) t.join();
  }
}
