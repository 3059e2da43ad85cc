// The micrometer-modbus driver against a Modbus stack written elsewhere: Debian's python3-pymodbus
// serving docs/protocols.md's register maps (tests/drivers/pymodbus_amplifier.py), over Modbus TCP and over
// Modbus RTU on a pseudo-terminal pair. Both word orders, input and holding registers, float32, the
// buffered ring (across the 32-bit counter wrap), status flags, the foreign server's exception answers
// and slow answers, and an RTU line reached by a stable link (a /dev/serial/by-id name) that
// disappears and comes back. Skipped, saying why, where pymodbus is not installed.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/sample.hpp"
#include "driver_counters_support.hpp"
#include "driver_samples_support.hpp"
#include "drivers/micrometer/micrometer_driver.hpp"
#include "test_support.hpp"

extern char** environ;

using namespace guideway;
using namespace std::chrono_literals;
using drivers::DeviceState;

namespace {

const std::string amplifier_script = std::string(GUIDEWAY_SOURCE_DIR) + "/tests/drivers/pymodbus_amplifier.py";

// Why the foreign stack cannot run here ("" when it can).
std::string pymodbus_missing() {
  static const std::string why = [] {
    if (::access("/usr/bin/python3", X_OK) != 0) return std::string("/usr/bin/python3 is not installed");
    const int rc = std::system("/usr/bin/python3 -c 'import pymodbus, serial_asyncio' >/dev/null 2>&1");
    if (rc != 0)
      return std::string(
          "python3-pymodbus or python3-serial-asyncio is not installed (scripts/setup.sh installs them)");
    return std::string();
  }();
  return why;
}

// tests/drivers/pymodbus_amplifier.py as a child process: its stdout read line by line, commands on its stdin.
class Amplifier {
 public:
  explicit Amplifier(const std::vector<std::string>& args) {
    int in[2], out[2];
    if (::pipe2(in, O_CLOEXEC) != 0 || ::pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("pipe");
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, in[0], 0);
    posix_spawn_file_actions_adddup2(&fa, out[1], 1);
    std::vector<std::string> argv_s{"/usr/bin/python3", amplifier_script};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, argv[0], &fa, nullptr, argv.data(), environ) != 0) throw std::runtime_error("spawn");
    posix_spawn_file_actions_destroy(&fa);
    ::close(in[0]);
    ::close(out[1]);
    to_ = in[1];
    from_ = out[0];
    version = line();
    endpoint = line();
    if (endpoint.rfind("endpoint: ", 0) != 0) throw std::runtime_error("amplifier said: " + version + " / " + endpoint);
    endpoint = endpoint.substr(10);
  }
  ~Amplifier() {
    ::close(to_);  // end of stdin: it quits
    int status = 0;
    for (int i = 0; i < 100 && ::waitpid(pid_, &status, WNOHANG) == 0; ++i) std::this_thread::sleep_for(10ms);
    if (::waitpid(pid_, &status, WNOHANG) == 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, &status, 0);
    }
    ::close(from_);
  }
  // The next line it printed (waits up to 10 s).
  std::string line() {
    for (;;) {
      const auto nl = buffer_.find('\n');
      if (nl != std::string::npos) {
        std::string l = buffer_.substr(0, nl);
        buffer_.erase(0, nl + 1);
        return l;
      }
      pollfd p{from_, POLLIN, 0};
      if (::poll(&p, 1, 10000) <= 0) throw std::runtime_error("the amplifier said nothing for 10 s");
      char buf[512];
      const ssize_t n = ::read(from_, buf, sizeof buf);
      if (n <= 0) throw std::runtime_error("the amplifier exited");
      buffer_.append(buf, static_cast<std::size_t>(n));
    }
  }
  // Sends a command; true when it answered "ok".
  bool command(const std::string& c) {
    const std::string l = c + "\n";
    if (::write(to_, l.data(), l.size()) != static_cast<ssize_t>(l.size())) return false;
    return line() == "ok";
  }
  // The driver's transport keys for this amplifier.
  [[nodiscard]] std::string transport_keys(const std::string& rtu_device = "") const {
    if (endpoint.rfind("tcp:", 0) == 0) {
      const auto colon = endpoint.rfind(':');
      return "transport = \"tcp\"\nhost = \"127.0.0.1\"\nport = " + endpoint.substr(colon + 1) + "\n";
    }
    const std::string device = rtu_device.empty() ? endpoint.substr(4) : rtu_device;
    return "transport = \"rtu\"\ndevice = \"" + device + "\"\nbaud = 19200\nparity = \"E\"\n";
  }

  std::string version;
  std::string endpoint;

 private:
  pid_t pid_ = -1;
  int to_ = -1;
  int from_ = -1;
  std::string buffer_;
};

std::int32_t ring_value(std::uint64_t n) {  // as pymodbus_amplifier.py
  return static_cast<std::int32_t>((n * 7919) % 200001) - 100000;
}

struct Device {
  Device(const std::string& keys, const std::string& name = "gauge") {
    table = parse_toml(keys, "foreign.toml");
    TableReader reader(table, "foreign.toml", "device[0]");
    driver = std::make_unique<drivers::micrometer::MicrometerDriver>(
        name, drivers::micrometer::parse_micrometer_config(reader), 1 << 15);
    reader.reject_unknown_keys();
    driver->start();
  }
  ~Device() { driver->stop(); }
  void drain() { test::drain_samples(*driver, samples); }
  bool wait_samples(std::size_t n) { return test::wait_samples(*driver, samples, n); }
  // Waits for `n` more samples and returns them.
  std::vector<Sample> next(std::size_t n) {
    const std::size_t from = samples.size();
    EXPECT_TRUE(wait_samples(from + n)) << driver->status().reason;
    return {samples.begin() + static_cast<std::ptrdiff_t>(from), samples.end()};
  }
  std::uint64_t counter(const std::string& name) { return test::driver_counters_by_name(driver->status()).at(name); }

  toml::table table;
  std::unique_ptr<drivers::micrometer::MicrometerDriver> driver;
  std::vector<Sample> samples;
};

const std::string polled_keys =
    "poll_hz = 200\nresponse_timeout_ms = 200\nlost_after_failures = 3\n"
    "reconnect_min_ms = 50\nreconnect_max_ms = 200\n";

// The three polled maps of pymodbus_amplifier.py, as [device.registers] tables.
struct PolledMap {
  const char* what;
  std::string registers;
  double value_m;
};
const PolledMap polled_maps[] = {
    {"input registers, int32 high word first",
     "[registers]\nfunction = \"input\"\nvalue_address = 0\n"
     "value_type = \"int32\"\nword_order = \"big\"\nstatus_address = 2\n",
     -123456 * 0.01e-6},
    {"holding registers, int32 low word first",
     "[registers]\nfunction = \"holding\"\nvalue_address = 10\n"
     "value_type = \"int32\"\nword_order = \"little\"\nstatus_address = 12\n",
     654321 * 0.01e-6},
    {"holding registers, float32",
     "[registers]\nfunction = \"holding\"\nvalue_address = 20\nvalue_type = \"float32\"\n"
     "scale_um = 1.0\nstatus_address = 22\n",
     12.5e-6},
};

void check_polled_map(Amplifier& amp, const PolledMap& m, const std::string& transport) {
  SCOPED_TRACE(m.what);
  Device d(transport + polled_keys + m.registers);
  for (const Sample& s : d.next(10)) {
    EXPECT_EQ(s.flags, 0u);
    EXPECT_NEAR(s.value[0], m.value_m, 1e-15);
  }
  // The amplifier's status bits: out of range, then no probe: flagged NaN, not numbers.
  ASSERT_TRUE(amp.command("status 1"));
  ASSERT_TRUE(test::eventually([&] {
    d.drain();
    return !d.samples.empty() && (d.samples.back().flags & sample_out_of_range);
  }));
  EXPECT_TRUE(std::isnan(d.samples.back().value[0]));
  ASSERT_TRUE(amp.command("status 2"));
  ASSERT_TRUE(test::eventually([&] {
    d.drain();
    return !d.samples.empty() && (d.samples.back().flags & sample_no_signal);
  }));
  ASSERT_TRUE(amp.command("status 0"));
  ASSERT_TRUE(test::eventually([&] {
    d.drain();
    return !d.samples.empty() && d.samples.back().flags == 0;
  }));
  EXPECT_EQ(d.driver->status().counters.bad_frames, 0u);
  EXPECT_EQ(d.driver->status().state, DeviceState::streaming);
}

// Every sample of a buffered device is the amplifier's next ring sample: found by its first values,
// then checked one by one (value, out-of-range flag every 1000th), none lost, none repeated.
void check_ring_sequence(const std::vector<Sample>& samples, std::uint64_t start, bool has_status) {
  ASSERT_GE(samples.size(), 3u);
  std::uint64_t k0 = 0;
  bool found = false;
  for (std::uint64_t k = start; k < start + 100000 && !found; ++k) {
    bool all = true;
    for (std::uint64_t i = 0; i < 3 && all; ++i) {
      const std::uint64_t n = (k + i) % (1ull << 32);
      all = !std::isnan(samples[i].value[0]) && std::abs(samples[i].value[0] - ring_value(n) * 0.01e-6) < 1e-12;
    }
    if (all) {
      k0 = k;
      found = true;
    }
  }
  ASSERT_TRUE(found) << "the first samples are no run of the amplifier's ring";
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const std::uint64_t n = (k0 + i) % (1ull << 32);
    if (has_status && n % 1000 == 999) {
      ASSERT_TRUE(samples[i].flags & sample_out_of_range) << i;
      ASSERT_TRUE(std::isnan(samples[i].value[0])) << i;
    } else {
      ASSERT_NEAR(samples[i].value[0], ring_value(n) * 0.01e-6, 1e-12) << "sample " << i << " = ring sample " << n;
    }
    if (i > 0) {
      ASSERT_EQ(samples[i].seq, samples[i - 1].seq + 1);
    }
  }
}

const std::string input_ring =
    "poll_period_ms = 20\nresponse_timeout_ms = 200\nlost_after_failures = 3\nreconnect_min_ms = 50\n"
    "[buffer]\nfunction = \"input\"\ncounter_address = 100\ncounter_word_order = \"big\"\nring_address = 200\n"
    "ring_samples = 512\nsample_rate_hz = 1000\nvalue_type = \"int32\"\nword_order = \"big\"\nstatus = true\n";
const std::string holding_ring =
    "poll_period_ms = 20\nresponse_timeout_ms = 200\nlost_after_failures = 3\nreconnect_min_ms = 50\n"
    "[buffer]\nfunction = \"holding\"\ncounter_address = 300\ncounter_word_order = \"little\"\nring_address = 400\n"
    "ring_samples = 512\nsample_rate_hz = 1000\nvalue_type = \"int32\"\nword_order = \"little\"\nstatus = false\n";

#define SKIP_WITHOUT_PYMODBUS()                                          \
  do {                                                                   \
    if (!pymodbus_missing().empty()) GTEST_SKIP() << pymodbus_missing(); \
  } while (0)

}  // namespace

TEST(MicrometerForeignStack, PolledMapsOverTcp) {
  SKIP_WITHOUT_PYMODBUS();
  Amplifier amp({"--tcp", "0", "--ring-rate-hz", "0"});
  RecordProperty("pymodbus", amp.version);
  for (const auto& m : polled_maps) check_polled_map(amp, m, amp.transport_keys());
}

TEST(MicrometerForeignStack, PolledMapsOverRtu) {
  SKIP_WITHOUT_PYMODBUS();
  Amplifier amp({"--rtu", "--ring-rate-hz", "0"});
  for (const auto& m : polled_maps) check_polled_map(amp, m, amp.transport_keys());
}

// Both rings at once (input ABCD with status, holding CDAB without), 1 kHz, across the 32-bit wrap
// of the amplifier's sample counter: every sample, in order.
TEST(MicrometerForeignStack, BufferedRingsInBothWordOrdersAcrossTheCounterWrap) {
  SKIP_WITHOUT_PYMODBUS();
  const std::uint64_t start = (1ull << 32) - 400;
  Amplifier amp({"--tcp", "0", "--ring-rate-hz", "1000", "--counter-start", std::to_string(start)});
  Device in(amp.transport_keys() + input_ring, "in");
  Device hold(amp.transport_keys() + holding_ring, "hold");
  ASSERT_TRUE(in.wait_samples(1500)) << in.driver->status().reason;
  ASSERT_TRUE(hold.wait_samples(1500)) << hold.driver->status().reason;
  in.driver->stop();
  hold.driver->stop();
  in.drain();
  hold.drain();
  check_ring_sequence(in.samples, start, true);
  check_ring_sequence(hold.samples, start, false);
  for (auto* d : {&in, &hold}) {
    EXPECT_EQ(d->counter("lost_samples"), 0u);
    EXPECT_EQ(d->counter("counter_resets"), 0u) << "the wrap is no restart";
    EXPECT_EQ(d->driver->status().counters.bad_frames, 0u);
  }
  RecordProperty("ring_samples_checked", std::to_string(in.samples.size() + hold.samples.size()));
}

TEST(MicrometerForeignStack, BufferedRingOverRtu) {
  SKIP_WITHOUT_PYMODBUS();
  Amplifier amp({"--rtu", "--ring-rate-hz", "1000"});
  Device in(amp.transport_keys() + input_ring);
  ASSERT_TRUE(in.wait_samples(800)) << in.driver->status().reason;
  in.driver->stop();
  in.drain();
  check_ring_sequence(in.samples, 0, true);
  EXPECT_EQ(in.counter("lost_samples"), 0u);
}

// pymodbus's exception answers (02, illegal data address) and answers later than the response
// timeout, as docs/protocols.md says: each counted, the next sample after a gap, `lost` after
// lost_after_failures in a row and back; in buffered mode a slow answer loses nothing.
TEST(MicrometerForeignStack, ExceptionsAndSlowAnswersAreHandledAsDocumented) {
  SKIP_WITHOUT_PYMODBUS();
  for (const bool rtu : {false, true}) {
    SCOPED_TRACE(rtu ? "RTU" : "TCP");
    Amplifier amp(rtu ? std::vector<std::string>{"--rtu", "--ring-rate-hz", "0"}
                      : std::vector<std::string>{"--tcp", "0", "--ring-rate-hz", "0"});
    Device d(amp.transport_keys() + polled_keys + polled_maps[0].registers);
    d.next(5);
    const std::size_t before = d.samples.size();
    ASSERT_TRUE(amp.command("exception 2"));
    ASSERT_TRUE(test::eventually([&] { return d.counter("exceptions") >= 2; }));
    // Waited for, not counted: on a loaded machine three or more samples polled before the exceptions
    // (the command reaches the amplifier through a pipe) may be all a drain finds.
    EXPECT_TRUE(test::eventually([&] {
      d.drain();
      return std::any_of(d.samples.begin() + static_cast<std::ptrdiff_t>(before), d.samples.end(),
                         [](const Sample& s) { return (s.flags & sample_after_gap) != 0; });
    })) << "the sample after the failed polls says so";
    EXPECT_EQ(d.driver->status().state, DeviceState::streaming);
    EXPECT_GE(d.driver->status().counters.bad_frames, 2u);
    // Three in a row: lost, reconnected, streaming again.
    ASSERT_TRUE(amp.command("exception 3"));
    ASSERT_TRUE(test::eventually([&] { return d.driver->status().state == DeviceState::lost; }, 5s));
    EXPECT_NE(d.driver->status().reason.find("address"), std::string::npos) << d.driver->status().reason;
    ASSERT_TRUE(test::eventually([&] { return d.driver->status().state == DeviceState::streaming; }, 5s));
    EXPECT_GE(d.driver->status().counters.reconnects, 1u);
    // An answer 0.3 s late, after the 200 ms timeout: a timeout, not the next reading (on RTU the
    // Report Server ID probe brings the line back in step: the late answer is dropped as stale).
    const auto timeouts = d.driver->status().counters.timeouts;
    ASSERT_TRUE(amp.command("slow 0.3 1"));
    ASSERT_TRUE(test::eventually([&] { return d.driver->status().counters.timeouts > timeouts; }, 5s));
    for (const Sample& s : d.next(10)) {
      EXPECT_TRUE(s.flags == 0 || s.flags == sample_after_gap) << s.flags;
      EXPECT_NEAR(s.value[0], polled_maps[0].value_m, 1e-15);
    }
    if (rtu) {
      EXPECT_GE(d.counter("stale_answers"), 1u) << "the late answer was recognised and dropped";
    }
    EXPECT_EQ(d.driver->status().state, DeviceState::streaming);
  }
  Amplifier amp({"--tcp", "0", "--ring-rate-hz", "1000"});
  Device ring(amp.transport_keys() + input_ring);
  ASSERT_TRUE(ring.wait_samples(100));
  ASSERT_TRUE(amp.command("slow 0.3 1"));  // the ring holds 0.512 s
  ASSERT_TRUE(test::eventually([&] { return ring.driver->status().counters.timeouts >= 1; }, 5s));
  ASSERT_TRUE(ring.wait_samples(ring.samples.size() + 500));
  ring.driver->stop();
  ring.drain();
  check_ring_sequence(ring.samples, 0, true);
  EXPECT_EQ(ring.counter("lost_samples"), 0u) << "a slow answer within the ring's length loses nothing";
}

// An RTU line reached by its stable name (as /dev/serial/by-id/...): unplugged, the link goes and the
// driver says why; plugged in again (another /dev/pts/N behind the same name), it is found again.
TEST(MicrometerForeignStack, AnRtuLineByItsStableNameIsFoundAgainAfterItComesBack) {
  SKIP_WITHOUT_PYMODBUS();
  test::TempDir dir;
  const std::string link = dir.file("usb-FTDI_FT232R_A5XK3RJT-if00-port0");
  Amplifier amp({"--rtu", "--ring-rate-hz", "0", "--link", link});
  ASSERT_EQ(amp.line(), "link: " + link);
  Device d(amp.transport_keys(link) + polled_keys + polled_maps[0].registers);
  d.next(5);
  ASSERT_TRUE(amp.command("unplug 0.6"));
  ASSERT_TRUE(test::eventually([&] {
    const auto st = d.driver->status();
    return st.state == DeviceState::lost && st.reason.find(link) != std::string::npos &&
           st.reason.find("No such file") != std::string::npos;
  })) << d.driver->status().reason;
  ASSERT_TRUE(test::eventually([&] {
    const auto st = d.driver->status();
    return st.state == DeviceState::streaming && st.counters.reconnects >= 1;
  })) << d.driver->status().reason;
  for (const Sample& s : d.next(5)) EXPECT_NEAR(s.value[0], polled_maps[0].value_m, 1e-15);
  EXPECT_TRUE(std::filesystem::is_symlink(link));
}
