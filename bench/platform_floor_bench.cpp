// What this machine charges for the two things a low-latency acquisition daemon cannot avoid, with
// nothing of Guideway in the loop: waking a thread on a timer, and taking a CAN frame off a socket;
// and each instrument's bare read on its own transport (its reader floor).
// Item 6 of issue #8 asks for four instruments at 10 kHz in under 5 % of a core with a p99 below
// 1 ms; these figures are the floor any design pays on this kernel (bench/README.md, "The floor").
//
// Times are CPU time of the measuring thread (CLOCK_THREAD_CPUTIME_ID, which includes the kernel's
// work on its behalf), reported as manual time: wall time would count the sleeps.
#include <benchmark/benchmark.h>

#include <fcntl.h>
#include <linux/can.h>
#include <linux/futex.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/timerfd.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstdint>
#include <ctime>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "drivers/autocollimator/autocollimator_protocol.hpp"
#include "drivers/modbus/modbus_tcp.hpp"
#include "drivers/modbus/sample_ring.hpp"
#include "drivers/profilometer/profile_stream.hpp"
#include "drivers/tcp/tcp_client.hpp"

namespace {

std::int64_t clock_ns(clockid_t clock) {
  timespec t{};
  clock_gettime(clock, &t);
  return std::int64_t{t.tv_sec} * 1'000'000'000 + t.tv_nsec;
}
std::int64_t thread_cpu_ns() { return clock_ns(CLOCK_THREAD_CPUTIME_ID); }
std::int64_t mono_ns() { return clock_ns(CLOCK_MONOTONIC); }
timespec to_timespec(std::int64_t ns) { return timespec{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)}; }

// A connected AF_UNIX SOCK_SEQPACKET pair: the transport dbb-can reads where AF_CAN is missing, and
// the one the benchmark's DBB emulator serves. Same per-datagram shape as a SocketCAN raw socket.
struct FramePair {
  int rx = -1;
  int tx = -1;
  explicit FramePair(bool receive_timestamps) {
    int sv[2];
    if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) != 0) throw std::runtime_error("socketpair");
    rx = sv[0];
    tx = sv[1];
    const int big = 4 << 20;
    (void)::setsockopt(tx, SOL_SOCKET, SO_SNDBUF, &big, sizeof big);
    (void)::setsockopt(rx, SOL_SOCKET, SO_RCVBUF, &big, sizeof big);
    const int on = 1;
    if (receive_timestamps) (void)::setsockopt(rx, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on);
  }
  ~FramePair() {
    ::close(rx);
    ::close(tx);
  }
  FramePair(const FramePair&) = delete;
  FramePair& operator=(const FramePair&) = delete;
  // Queues up to n frames; returns how many fitted.
  int fill(int n) const {
    can_frame f{};
    f.can_dlc = 8;
    int sent = 0;
    while (sent < n && ::send(tx, &f, sizeof f, MSG_DONTWAIT) == static_cast<ssize_t>(sizeof f)) ++sent;
    return sent;
  }
};

// The driver's read: recvmmsg in batches of 64, each frame with room for its timestamp cmsg.
struct BatchReader {
  static constexpr int batch = 64;
  std::array<can_frame, batch> frames{};
  std::array<iovec, batch> iov{};
  std::array<mmsghdr, batch> msgs{};
  alignas(cmsghdr) std::array<std::array<unsigned char, CMSG_SPACE(sizeof(timespec)) + 32>, batch> control{};
  std::int64_t stamp_sum = 0;  // keeps the timestamp parsing from being optimised away

  int drain(int fd) {
    int total = 0;
    for (;;) {
      for (int i = 0; i < batch; ++i) {
        iov[i] = {&frames[i], sizeof(can_frame)};
        msgs[i] = {};
        msgs[i].msg_hdr.msg_iov = &iov[i];
        msgs[i].msg_hdr.msg_iovlen = 1;
        msgs[i].msg_hdr.msg_control = control[i].data();
        msgs[i].msg_hdr.msg_controllen = control[i].size();
      }
      const int n = ::recvmmsg(fd, msgs.data(), batch, MSG_DONTWAIT, nullptr);
      if (n <= 0) return total;
      for (int i = 0; i < n; ++i) {
        for (cmsghdr* c = CMSG_FIRSTHDR(&msgs[i].msg_hdr); c != nullptr; c = CMSG_NXTHDR(&msgs[i].msg_hdr, c)) {
          if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
            timespec t{};
            __builtin_memcpy(&t, CMSG_DATA(c), sizeof t);
            stamp_sum += t.tv_nsec;
          }
        }
      }
      total += n;
      if (n < batch) return total;
    }
  }
};

int drain_one_by_one(int fd) {
  can_frame f{};
  int total = 0;
  while (::recv(fd, &f, sizeof f, MSG_DONTWAIT) == static_cast<ssize_t>(sizeof f)) ++total;
  return total;
}

// ---- Timed wake-ups: one iteration is one sleep of `period` and the wake-up after it. ----------
// The ways a Guideway thread waits: clock_nanosleep (a plain rest), ppoll with a timeout (dbb-can
// in listen mode), a futex wait with a timeout (the pipeline's doorbell), and epoll_wait on a
// timerfd (what one I/O thread serving every device would use).
enum class Waiter { clock_nanosleep, ppoll, futex, epoll_timerfd };

template <Waiter W>
void BM_TimedWakeup(benchmark::State& state) {
  const std::int64_t period_ns = state.range(0) * 1000;
  int idle[2];
  if (::pipe2(idle, O_CLOEXEC) != 0) {
    state.SkipWithError("pipe2 failed");
    return;
  }
  const int ep = ::epoll_create1(EPOLL_CLOEXEC);
  const int tfd = ::timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC | TFD_NONBLOCK);
  epoll_event ev{};
  ev.events = EPOLLIN;
  (void)::epoll_ctl(ep, EPOLL_CTL_ADD, tfd, &ev);
  const itimerspec every{to_timespec(period_ns), to_timespec(period_ns)};
  if (W == Waiter::epoll_timerfd) (void)::timerfd_settime(tfd, 0, &every, nullptr);
  std::atomic<std::uint32_t> word{0};
  std::int64_t next = mono_ns();
  std::int64_t wall0 = 0;
  std::int64_t cpu_total = 0;
  for (auto _ : state) {
    if (wall0 == 0) wall0 = mono_ns();
    const std::int64_t cpu0 = thread_cpu_ns();
    next += period_ns;
    if constexpr (W == Waiter::clock_nanosleep) {
      const timespec t = to_timespec(next);
      ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr);
    } else if constexpr (W == Waiter::ppoll) {
      pollfd p{idle[0], POLLIN, 0};
      const timespec t = to_timespec(period_ns);
      ::ppoll(&p, 1, &t, nullptr);
    } else if constexpr (W == Waiter::futex) {
      const timespec t = to_timespec(period_ns);
      ::syscall(SYS_futex, reinterpret_cast<std::uint32_t*>(&word), FUTEX_WAIT_PRIVATE, 0, &t, nullptr, 0);
    } else {
      epoll_event out{};
      ::epoll_wait(ep, &out, 1, -1);
      std::uint64_t expirations = 0;
      (void)::read(tfd, &expirations, sizeof expirations);
    }
    const std::int64_t cpu = thread_cpu_ns() - cpu0;
    cpu_total += cpu;
    state.SetIterationTime(static_cast<double>(cpu) * 1e-9);
  }
  const double wall_s = static_cast<double>(mono_ns() - wall0) * 1e-9;
  const double wakes_per_s = static_cast<double>(state.iterations()) / wall_s;
  state.counters["wakes_per_s"] = wakes_per_s;
  state.counters["cpu_us_per_wake"] = static_cast<double>(cpu_total) * 1e-3 / static_cast<double>(state.iterations());
  state.counters["core_pct"] = static_cast<double>(cpu_total) * 1e-9 / wall_s * 100.0;
  ::close(idle[0]);
  ::close(idle[1]);
  ::close(tfd);
  ::close(ep);
}

// 1 ms: one I/O thread per period for a sub-millisecond p99; 300 us: dbb-can's default read period.
BENCHMARK(BM_TimedWakeup<Waiter::clock_nanosleep>)->Name("TimedWakeup/clock_nanosleep")->Arg(1000)->Arg(300)->Iterations(3000)->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_TimedWakeup<Waiter::ppoll>)->Name("TimedWakeup/ppoll")->Arg(1000)->Arg(300)->Iterations(3000)->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_TimedWakeup<Waiter::futex>)->Name("TimedWakeup/futex")->Arg(1000)->Arg(300)->Iterations(3000)->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_TimedWakeup<Waiter::epoll_timerfd>)->Name("TimedWakeup/epoll_timerfd")->Arg(1000)->Arg(300)->Iterations(3000)->UseManualTime()->Unit(benchmark::kMicrosecond);

// ---- A system call that does nothing, for scale: what entering the kernel costs without a wake-up.
void BM_Syscall(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(::syscall(SYS_getppid));
}
BENCHMARK(BM_Syscall)->Name("Syscall/getppid")->MeasureProcessCPUTime()->Unit(benchmark::kMicrosecond);

// ---- Frames already queued: the CPU to take them off the socket, no wake-up involved. ----------
enum class Drain { recvmmsg_timestamped, recvmmsg, recv_each };

template <Drain D>
void BM_CanFrameDrain(benchmark::State& state) {
  const int queued = static_cast<int>(state.range(0));
  FramePair pair(D == Drain::recvmmsg_timestamped);
  BatchReader reader;
  std::int64_t frames = 0;
  for (auto _ : state) {
    const int filled = pair.fill(queued);
    if (filled != queued) {
      state.SkipWithError(("only " + std::to_string(filled) + " frames fitted in the socket").c_str());
      break;
    }
    const std::int64_t cpu0 = thread_cpu_ns();
    const int got = D == Drain::recv_each ? drain_one_by_one(pair.rx) : reader.drain(pair.rx);
    state.SetIterationTime(static_cast<double>(thread_cpu_ns() - cpu0) * 1e-9);
    frames += got;
  }
  benchmark::DoNotOptimize(reader.stamp_sum);
  state.SetItemsProcessed(frames);
}
// 36: the frames of one 900 us period at 10 kHz x 4 frames per cycle (SYNC + three TPDOs).
BENCHMARK(BM_CanFrameDrain<Drain::recvmmsg_timestamped>)->Name("CanFrameDrain/recvmmsg_timestamped")->Arg(36)->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CanFrameDrain<Drain::recvmmsg>)->Name("CanFrameDrain/recvmmsg")->Arg(36)->UseManualTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_CanFrameDrain<Drain::recv_each>)->Name("CanFrameDrain/recv_each")->Arg(36)->UseManualTime()->Unit(benchmark::kMicrosecond);

// ---- A reader's floor: one thread that wakes every `period_ns` (an absolute deadline, as a rest of
// the daemon's keeps its phase), reads what its transport holds with `read` (returning the items
// taken) and does nothing else. Its CPU (the kernel's work on its behalf included) and its wake-ups
// (voluntary context switches, as controller_load.py counts them for guidewayd) per second of wall time.
template <class Read>
void run_reader_floor(benchmark::State& state, std::int64_t period_ns, Read&& read) {
  std::int64_t items = 0;
  std::int64_t cpu_total = 0;
  rusage ru0{};
  ::getrusage(RUSAGE_THREAD, &ru0);
  std::int64_t next = mono_ns();
  const std::int64_t wall0 = next;
  for (auto _ : state) {
    const std::int64_t cpu0 = thread_cpu_ns();
    next += period_ns;
    const timespec t = to_timespec(next);
    ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr);
    items += read();
    const std::int64_t cpu = thread_cpu_ns() - cpu0;
    cpu_total += cpu;
    state.SetIterationTime(static_cast<double>(cpu) * 1e-9);
  }
  rusage ru1{};
  ::getrusage(RUSAGE_THREAD, &ru1);
  const double wall_s = static_cast<double>(mono_ns() - wall0) * 1e-9;
  state.SetItemsProcessed(items);
  state.counters["items_per_s"] = static_cast<double>(items) / wall_s;
  state.counters["core_pct"] = static_cast<double>(cpu_total) * 1e-9 / wall_s * 100.0;
  state.counters["wakes_per_s"] = static_cast<double>(ru1.ru_nvcsw - ru0.ru_nvcsw) / wall_s;
}

// A feeder thread standing in for an instrument: runs `step(now_ns)` every `period_ns` until destroyed.
class Feeder {
 public:
  template <class Step>
  Feeder(std::int64_t period_ns, Step step)
      : thread_([this, period_ns, step = std::move(step)]() mutable {
          std::int64_t next = mono_ns();
          while (!stop_.load(std::memory_order_relaxed)) {
            next += period_ns;
            const timespec t = to_timespec(next);
            ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr);
            step(mono_ns());
          }
        }) {}
  ~Feeder() { stop_ = true; }  // before the thread is joined (members are destroyed in reverse)

 private:
  std::atomic<bool> stop_{false};
  std::jthread thread_;
};

// ---- The instruments' traffic and their bare readers, each as a link: the instrument (a feeder
// thread of this process making what bench/daemon_load.py's emulator makes at full rate, on the same
// kind of transport) and the reader's side, whose read() takes what is queued with the driver's own
// decoding and hands nothing on (no ring, no pipeline). Alone, each is one instrument's floor (issue
// 45: "a floor for that instrument, the same reader with nothing behind it"); together on one thread,
// the floor of all four.

// The DBB: 10 k cycles/s of 4 frames (SYNC and three TPDOs) on a SOCK_SEQPACKET pair, a cycle every
// 100 us with its frames sent together as the emulator does; read in batches, nothing parsed.
struct DbbLink {
  static constexpr std::int64_t frames_per_s = 40'000;
  explicit DbbLink(bool timestamps) : pair(timestamps) { f.can_dlc = 8; }
  FramePair pair;
  can_frame f{};
  std::int64_t sent = 0;
  const std::int64_t t0 = mono_ns();
  Feeder feeder{100'000, [this](std::int64_t now) {
                  const std::int64_t due = (now - t0) * frames_per_s / 1'000'000'000;
                  for (; sent < due; ++sent) (void)::send(pair.tx, &f, sizeof f, MSG_DONTWAIT);
                }};
  BatchReader reader;
  std::int64_t read() { return reader.drain(pair.rx); }
};

// A connected TCP pair on the loopback: the instrument's end (blocking) and the reader's (non-blocking,
// TCP_NODELAY and the kernel's receive time with every read, as the drivers' sockets).
struct TcpPair {
  int instrument = -1;
  int reader = -1;
  TcpPair() {
    const int listener = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    if (listener < 0 || ::bind(listener, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(listener, 1) != 0 ||
        ::getsockname(listener, reinterpret_cast<sockaddr*>(&a), &len) != 0)
      throw std::runtime_error("listen on the loopback");
    reader = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (::connect(reader, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("connect");
    instrument = ::accept4(listener, nullptr, nullptr, SOCK_CLOEXEC);
    ::close(listener);
    if (instrument < 0) throw std::runtime_error("accept");
    const int on = 1;
    (void)::setsockopt(instrument, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
    guideway::drivers::tcp::set_stream_options(reader);
    (void)::fcntl(reader, F_SETFL, ::fcntl(reader, F_GETFL) | O_NONBLOCK);
  }
  ~TcpPair() {
    ::close(reader);
    ::close(instrument);
  }
  TcpPair(const TcpPair&) = delete;
  TcpPair& operator=(const TcpPair&) = delete;
};

bool send_all(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t n = ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n <= 0) return false;
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

// A pseudo-terminal in raw mode, as the autocollimator emulator's --link: the instrument writes on
// its master side (never blocking), the reader reads its line without waiting.
struct PtyPair {
  int instrument = -1;
  int reader = -1;
  PtyPair() {
    instrument = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (instrument < 0 || ::grantpt(instrument) != 0 || ::unlockpt(instrument) != 0)
      throw std::runtime_error("no pseudo-terminal");
    (void)::fcntl(instrument, F_SETFL, ::fcntl(instrument, F_GETFL) | O_NONBLOCK);
    reader = ::open(::ptsname(instrument), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    for (const int fd : {reader, instrument}) {
      termios tio{};
      if (fd < 0 || ::tcgetattr(fd, &tio) != 0) throw std::runtime_error("cannot open the pseudo-terminal's line");
      ::cfmakeraw(&tio);
      (void)::tcsetattr(fd, TCSANOW, &tio);
    }
  }
  ~PtyPair() {
    ::close(reader);
    ::close(instrument);
  }
  PtyPair(const PtyPair&) = delete;
  PtyPair& operator=(const PtyPair&) = delete;
};

// The autocollimator: a TA80-style reply line every `line_ns` (1 ms: stream_period_ms = 1, the
// fastest the driver accepts) on a pseudo-terminal; each line parsed (parse_reply).
struct AutocollimatorLink {
  explicit AutocollimatorLink(std::int64_t line_ns) : feeder(line_ns, [this](std::int64_t) {
    (void)!::write(pty.instrument, reply.data(), reply.size());
  }) {}
  PtyPair pty;
  const std::string reply = [] {
    guideway::drivers::autocollimator::Reading r;
    r.x_arcsec = 12.34;
    r.y_arcsec = -56.78;
    return guideway::drivers::autocollimator::format_reply(r, 1000.0, false) + "\r";
  }();
  std::array<char, 4096> buf{};
  std::string pending;
  double sum = 0.0;
  Feeder feeder;
  std::int64_t read() {
    namespace ac = guideway::drivers::autocollimator;
    for (;;) {
      const ssize_t n = ::read(pty.reader, buf.data(), buf.size());
      if (n <= 0) break;
      pending.append(buf.data(), static_cast<std::size_t>(n));
    }
    std::int64_t lines = 0;
    std::size_t from = 0;
    for (std::size_t end; (end = pending.find('\r', from)) != std::string::npos; from = end + 1) {
      ac::Reading reading;
      if (ac::parse_reply(std::string_view(pending).substr(from, end - from), false, reading) == ac::ParseError::none) {
        sum += reading.x_arcsec;
        ++lines;
      }
    }
    pending.erase(0, from);
    return lines;
  }
};

// The micrometer in buffered mode over Modbus TCP: the amplifier (a server thread) samples at 10 kHz
// into a ring of 16384 slots, as bench/daemon_load.py's emulator, and answers each request as it comes.
// A poll is one write of the counter read and the ring reads of the samples taken since the last poll
// (as far as the amplifier will have got, planned as the driver plans them: plan_ring_reads), then the
// wait for their answers (parse_tcp_answer) and the decoding of counter and samples.
struct MicrometerLink {
  MicrometerLink() {
    ring.ring_samples = 16384;
    ring.sample_rate_hz = 10000.0;
    if (const std::string why = ring.validate(); !why.empty()) throw std::runtime_error(why);
    amplifier = std::jthread([this] { serve(); });
  }
  ~MicrometerLink() {
    ::shutdown(pair.reader, SHUT_RDWR);  // the amplifier's recv returns: it ends
    amplifier.join();
  }
  MicrometerLink(const MicrometerLink&) = delete;
  MicrometerLink& operator=(const MicrometerLink&) = delete;

  guideway::drivers::modbus::SampleRingMap ring;
  TcpPair pair;
  const std::int64_t t0 = mono_ns();
  std::uint16_t transaction = 0;
  std::uint64_t next = 0;     // the next sample to fetch
  std::uint64_t counter = 0;  // as the last poll read it
  std::int64_t last_poll = t0;
  std::vector<std::uint8_t> rx;
  std::vector<guideway::drivers::modbus::Reading> readings =
      std::vector<guideway::drivers::modbus::Reading>(ring.samples_per_request());
  std::array<std::uint16_t, 125> block{};
  double sum = 0.0;
  std::jthread amplifier;

  [[nodiscard]] std::uint64_t taken_by(std::int64_t now) const {
    return static_cast<std::uint64_t>(static_cast<double>(now - t0) * 1e-9 * ring.sample_rate_hz);
  }
  void serve() {
    namespace mb = guideway::drivers::modbus;
    std::vector<std::uint8_t> in;
    std::array<std::uint8_t, 512> buf{};
    for (;;) {
      const ssize_t n = ::recv(pair.instrument, buf.data(), buf.size(), 0);
      if (n <= 0) return;
      in.insert(in.end(), buf.begin(), buf.begin() + n);
      std::string out;
      while (in.size() >= mb::tcp_request_bytes) {
        const auto address = static_cast<std::uint16_t>(in[8] << 8 | in[9]);
        const auto count = static_cast<std::uint16_t>(in[10] << 8 | in[11]);
        std::vector<std::uint16_t> regs(count, 0);
        if (address == ring.counter_address && count == 2) {
          const auto c = mb::encode_counter(ring, static_cast<std::uint32_t>(taken_by(mono_ns())));
          regs = {c[0], c[1]};
        }
        const std::size_t length = 3 + 2 * std::size_t{count};  // unit, function, byte count, registers
        const std::uint8_t head[] = {in[0], in[1], 0, 0, static_cast<std::uint8_t>(length >> 8),
                                     static_cast<std::uint8_t>(length), in[6], in[7], static_cast<std::uint8_t>(2 * count)};
        out.append(reinterpret_cast<const char*>(head), sizeof head);
        for (const std::uint16_t r : regs) {
          out += static_cast<char>(r >> 8);
          out += static_cast<char>(r & 0xFF);
        }
        in.erase(in.begin(), in.begin() + mb::tcp_request_bytes);
      }
      if (!send_all(pair.instrument, out)) return;
    }
  }
  // One poll, its answers waited for: the samples decoded.
  std::int64_t poll() {
    namespace mb = guideway::drivers::modbus;
    namespace tcp = guideway::drivers::tcp;
    const std::int64_t now = mono_ns();
    const auto ahead =
        static_cast<std::uint64_t>(static_cast<double>(now - last_poll) * 1e-9 * ring.sample_rate_hz * 1.02) + 2;
    last_poll = now;
    const std::vector<mb::RingRead> reads = mb::plan_ring_reads(ring, next, counter + ahead);
    std::string requests;
    const auto ask = [&](std::uint16_t address, std::uint16_t count) {
      const auto r = mb::tcp_read_request(++transaction, 1, ring.function, address, count);
      requests.append(reinterpret_cast<const char*>(r.data()), r.size());
    };
    ask(ring.counter_address, 2);
    for (const mb::RingRead& r : reads) ask(r.address, r.count);
    if (!send_all(pair.reader, requests)) return 0;
    const auto first = static_cast<std::uint16_t>(transaction - reads.size());
    std::int64_t samples = 0;
    rx.clear();
    for (std::size_t answered = 0; answered <= reads.size();) {
      const std::uint16_t count = answered == 0 ? 2 : reads[answered - 1].count;
      const mb::TcpAnswer a =
          mb::parse_tcp_answer(rx, static_cast<std::uint16_t>(first + answered), 1, ring.function, count, block);
      if (a.kind == mb::TcpAnswer::Kind::incomplete) {
        pollfd p{pair.reader, POLLIN, 0};
        (void)::poll(&p, 1, 1000);
        std::array<char, 2048> buf{};
        const tcp::ReadResult r = tcp::read_some(pair.reader, buf.data(), buf.size());
        if (r.status == tcp::ReadStatus::data) {
          rx.insert(rx.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(r.bytes));
        } else if (r.status != tcp::ReadStatus::would_block) {
          return samples;
        }
        continue;
      }
      if (a.kind != mb::TcpAnswer::Kind::registers) return samples;
      rx.erase(rx.begin(), rx.begin() + static_cast<std::ptrdiff_t>(a.length));
      if (answered == 0) {
        counter = mb::decode_counter(ring, block[0], block[1]);
      } else if (const mb::RingRead& r = reads[answered - 1];
                 mb::decode_ring_block(ring, r, std::span<const std::uint16_t>(block.data(), r.count), readings)) {
        const std::uint64_t valid = counter > r.first ? std::min<std::uint64_t>(r.samples, counter - r.first) : 0;
        for (std::size_t i = 0; i < valid; ++i) sum += readings[i].value_m;
        samples += static_cast<std::int64_t>(valid);
      }
      ++answered;
    }
    next = std::max(next, counter);
    return samples;
  }
};

// The profilometer: point lines at 10 k points/s over TCP, sent as the emulator sends them (its points
// gathered until the next one is `segment_ns` = 2 ms ahead, then written at once); read with the
// driver's read (tcp::read_some, the receive time) and assembled (ProfileAssembler: lines, checksums,
// points).
struct ProfilometerLink {
  static constexpr double points_per_s = 10'000.0;
  explicit ProfilometerLink(std::int64_t segment_ns)
      : feeder(segment_ns, [this, segment_ns](std::int64_t now) {
          namespace pr = guideway::drivers::profilometer;
          std::string out = started ? std::string() : pr::format_banner("floor") + pr::format_header(header);
          started = true;
          const auto due = static_cast<std::uint64_t>(static_cast<double>(now - t0 + segment_ns) * 1e-9 * points_per_s);
          for (; sent < due; ++sent) out += pr::format_point(sent, static_cast<double>(sent) * 1e-6, 1e-7, header);
          (void)send_all(pair.instrument, out);
        }) {}
  TcpPair pair;
  const guideway::drivers::profilometer::ProfileHeader header = [] {
    guideway::drivers::profilometer::ProfileHeader h;
    h.id = 1;
    h.points = 1'000'000'000;
    h.length_m = 1.0;
    h.spacing_m = 1e-6;
    return h;
  }();
  const std::int64_t t0 = mono_ns();
  std::uint64_t sent = 0;
  bool started = false;
  guideway::drivers::profilometer::ProfileAssembler assembler;
  std::vector<guideway::drivers::profilometer::StreamEvent> events;
  std::array<char, 16384> buf{};
  double sum = 0.0;
  Feeder feeder;
  std::int64_t read() {
    namespace tcp = guideway::drivers::tcp;
    std::int64_t points = 0;
    for (;;) {
      const tcp::ReadResult r = tcp::read_some(pair.reader, buf.data(), buf.size());
      if (r.status != tcp::ReadStatus::data) break;
      assembler.feed(std::string_view(buf.data(), r.bytes), r.rx_realtime_ns, events);
      for (const auto& e : events) {
        if (e.type == guideway::drivers::profilometer::StreamEvent::Type::point) {
          sum += e.z_m;
          ++points;
        }
      }
      events.clear();
      if (r.bytes < buf.size()) break;
    }
    return points;
  }
};

// ---- The least a DBB reader can cost: one thread that wakes every 900 us (p99 just under 1 ms) and
// takes everything queued. Nothing is parsed, stamped into samples or handed on. --------------------
void BM_DbbReaderFloor(benchmark::State& state) {
  DbbLink dbb(state.range(1) != 0);
  run_reader_floor(state, state.range(0) * 1000, [&] { return dbb.read(); });
  benchmark::DoNotOptimize(dbb.reader.stamp_sum);
  state.counters["frames_per_s"] = state.counters["items_per_s"];
}
BENCHMARK(BM_DbbReaderFloor)->Name("DbbReaderFloor")->ArgNames({"period_us", "timestamps"})->Args({900, 1})->Args({900, 0})->Iterations(3000)->UseManualTime()->Unit(benchmark::kMicrosecond);

// ---- The other three instruments' floors, each alone at the read period guidewayd uses for it: the
// streams every read_period_us (700), the micrometer every poll_period_ms (5) waiting for its answers.
void BM_AutocollimatorReaderFloor(benchmark::State& state) {
  AutocollimatorLink ac(state.range(1) * 1000);
  run_reader_floor(state, state.range(0) * 1000, [&] { return ac.read(); });
  benchmark::DoNotOptimize(ac.sum);
}
BENCHMARK(BM_AutocollimatorReaderFloor)->Name("AutocollimatorReaderFloor")->ArgNames({"period_us", "line_us"})->Args({700, 1000})->Iterations(3000)->UseManualTime()->Unit(benchmark::kMicrosecond);

void BM_MicrometerReaderFloor(benchmark::State& state) {
  MicrometerLink mic;
  run_reader_floor(state, state.range(0) * 1000, [&] { return mic.poll(); });
  benchmark::DoNotOptimize(mic.sum);
}
BENCHMARK(BM_MicrometerReaderFloor)->Name("MicrometerReaderFloor")->ArgNames({"period_us"})->Args({5000})->Iterations(600)->UseManualTime()->Unit(benchmark::kMicrosecond);

void BM_ProfilometerReaderFloor(benchmark::State& state) {
  ProfilometerLink prof(state.range(1) * 1000);
  run_reader_floor(state, state.range(0) * 1000, [&] { return prof.read(); });
  benchmark::DoNotOptimize(prof.sum);
}
BENCHMARK(BM_ProfilometerReaderFloor)->Name("ProfilometerReaderFloor")->ArgNames({"period_us", "segment_us"})->Args({700, 2000})->Iterations(3000)->UseManualTime()->Unit(benchmark::kMicrosecond);

// ---- All four on one thread, as guidewayd's I/O thread serves them: it wakes every 900 us (the DBB
// floor's period) and reads each stream; every poll period (5 ms) its wake-up also polls the micrometer
// and waits for the answers. The least one thread can spend on the four at full rate with the streams'
// points waiting at most a period; the daemon's own work (samples stamped into rings, the pipeline,
// the publishing) and its extra wake-ups for latency (answers and segments read as they come) are what
// it spends above this.
void BM_AllFourReaderFloor(benchmark::State& state) {
  const std::int64_t period_ns = state.range(0) * 1000;
  const std::int64_t poll_ns = state.range(1) * 1000;
  DbbLink dbb(true);
  AutocollimatorLink ac(1'000'000);
  MicrometerLink mic;
  ProfilometerLink prof(2'000'000);
  std::int64_t next_poll = mono_ns();
  run_reader_floor(state, period_ns, [&] {
    std::int64_t n = dbb.read() + ac.read() + prof.read();
    if (mono_ns() >= next_poll) {
      next_poll += poll_ns;
      n += mic.poll();
    }
    return n;
  });
  benchmark::DoNotOptimize(dbb.reader.stamp_sum);
  benchmark::DoNotOptimize(ac.sum + mic.sum + prof.sum);
}
BENCHMARK(BM_AllFourReaderFloor)->Name("AllFourReaderFloor")->ArgNames({"period_us", "poll_us"})->Args({900, 5000})->Iterations(3000)->UseManualTime()->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
