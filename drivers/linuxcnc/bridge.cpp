// guideway-linuxcnc-bridge (bridge.hpp): LinuxCNC's servo periods, read from halsampler, served to every client that
// asks.
#include "drivers/linuxcnc/bridge.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/epoll.h>
#include <sys/prctl.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <list>
#include <ostream>
#include <utility>

#include "drivers/linuxcnc/hal_stream.hpp"

namespace guideway::drivers::linuxcnc {

namespace {

std::string errno_text(const std::string& what) { return what + ": " + std::strerror(errno); }

class Fd {
 public:
  Fd() = default;
  explicit Fd(int fd) : fd_(fd) {}
  Fd(Fd&& o) noexcept : fd_(o.release()) {}
  Fd& operator=(Fd&& o) noexcept {
    if (this != &o) reset(o.release());
    return *this;
  }
  ~Fd() { reset(); }
  [[nodiscard]] int get() const { return fd_; }
  int release() { return std::exchange(fd_, -1); }
  void reset(int fd = -1) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = fd;
  }

 private:
  int fd_ = -1;
};

// The Unix socket the clients connect to. A socket file nobody answers on (a bridge that died) is
// replaced; one a bridge answers on is not: two bridges on one path would serve two LinuxCNCs' periods.
Fd listen_unix(const std::string& path, unsigned mode, std::string& error) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof(addr.sun_path)) {
    error = "socket path \"" + path + "\" is empty or too long";
    return {};
  }
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  {
    Fd probe(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0));
    if (probe.get() >= 0 && ::connect(probe.get(), reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0) {
      error = path + ": another bridge serves this socket";
      return {};
    }
  }
  ::unlink(path.c_str());
  Fd s(::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0));
  if (s.get() < 0 || ::bind(s.get(), reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      ::listen(s.get(), 8) != 0) {
    error = errno_text(path);
    return {};
  }
  ::chmod(path.c_str(), mode);
  return s;
}

// The source program with its stdout on a pipe; it dies with the bridge.
pid_t spawn_source(const std::vector<std::string>& command, Fd& out, std::string& error) {
  int p[2];
  if (::pipe2(p, O_CLOEXEC) != 0) {
    error = errno_text("pipe");
    return -1;
  }
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    error = errno_text("fork");
    ::close(p[0]);
    ::close(p[1]);
    return -1;
  }
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (::getppid() != parent) _exit(1);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::dup2(p[1], STDOUT_FILENO);
    std::vector<char*> argv;
    for (const auto& a : command) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execvp(argv[0], argv.data());
    const std::string msg = "guideway-linuxcnc-bridge: cannot run " + command[0] + ": " + std::strerror(errno) + "\n";
    [[maybe_unused]] auto ignored = ::write(STDERR_FILENO, msg.data(), msg.size());
    _exit(127);
  }
  ::close(p[1]);
  out.reset(p[0]);
  ::fcntl(out.get(), F_SETFL, ::fcntl(out.get(), F_GETFL) | O_NONBLOCK);
  return pid;
}

struct Client {
  Fd fd;
  std::string queue;
  std::uint64_t dropped = 0;  // periods not queued since the last `! lost` line
  bool writable_armed = false;
};

class Bridge {
 public:
  Bridge(const BridgeOptions& o, std::ostream& log) : o_(o), log_(log) {}
  int run(BridgeCounters& counters);

 private:
  bool start();
  void accept_clients();
  bool read_source();  // false at its end
  void source_line(std::string_view line);
  void broadcast(const std::string& line, bool is_period);
  void flush(Client& c);
  void close_client(std::list<Client>::iterator it);
  void watch(int fd, std::uint32_t events, int op = EPOLL_CTL_ADD);

  const BridgeOptions& o_;
  std::ostream& log_;
  BridgeCounters counters_;
  Fd epoll_, listener_, source_, signals_;
  pid_t source_pid_ = -1;
  std::list<Client> clients_;
  std::string partial_;
  std::string header_;
  std::vector<double> values_;
  bool have_seq_ = false;
  bool overrun_seen_ = false;
  std::int64_t last_seq_ = 0;
};

void Bridge::watch(int fd, std::uint32_t events, int op) {
  epoll_event ev{};
  ev.events = events;
  ev.data.fd = fd;
  ::epoll_ctl(epoll_.get(), op, fd, &ev);
}

bool Bridge::start() {
  std::string error;
  if (o_.columns.empty()) {
    log_ << "guideway-linuxcnc-bridge: no columns given\n";
    return false;
  }
  HalStreamHeader h;
  h.period_ns = o_.period_ns;
  h.columns = o_.columns;
  header_ = format_hal_stream_header(h);
  values_.assign(o_.columns.size(), 0.0);
  listener_ = listen_unix(o_.socket_path, o_.socket_mode, error);
  if (listener_.get() < 0) {
    log_ << "guideway-linuxcnc-bridge: " << error << "\n";
    return false;
  }
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGTERM);
  sigaddset(&stop, SIGINT);
  sigaddset(&stop, SIGHUP);
  ::sigprocmask(SIG_BLOCK, &stop, nullptr);
  ::signal(SIGPIPE, SIG_IGN);
  signals_.reset(::signalfd(-1, &stop, SFD_CLOEXEC));
  source_pid_ = spawn_source(o_.source_command, source_, error);
  if (source_pid_ < 0) {
    log_ << "guideway-linuxcnc-bridge: " << error << "\n";
    return false;
  }
  epoll_.reset(::epoll_create1(EPOLL_CLOEXEC));
  watch(listener_.get(), EPOLLIN);
  watch(source_.get(), EPOLLIN);
  watch(signals_.get(), EPOLLIN);
  log_ << "guideway-linuxcnc-bridge: serving " << o_.columns.size() << " columns every " << o_.period_ns
       << " ns on " << o_.socket_path << " (source: " << o_.source_command[0] << ")\n"
       << std::flush;
  return true;
}

int Bridge::run(BridgeCounters& counters) {
  if (!start()) return 1;
  bool running = true;
  epoll_event events[16];
  while (running) {
    const int n = ::epoll_wait(epoll_.get(), events, 16, -1);
    if (n < 0 && errno != EINTR) break;
    for (int i = 0; i < n && running; ++i) {
      const int fd = events[i].data.fd;
      if (fd == signals_.get()) {
        log_ << "guideway-linuxcnc-bridge: stop asked\n";
        running = false;
      } else if (fd == listener_.get()) {
        accept_clients();
      } else if (fd == source_.get()) {
        running = read_source();
      } else {
        for (auto it = clients_.begin(); it != clients_.end(); ++it) {
          if (it->fd.get() != fd) continue;
          bool gone = (events[i].events & (EPOLLERR | EPOLLHUP | EPOLLRDHUP)) != 0;
          if (!gone && (events[i].events & EPOLLIN)) {  // clients have nothing to say: read and drop
            char junk[256];
            const ssize_t got = ::recv(fd, junk, sizeof(junk), 0);
            gone = got == 0 || (got < 0 && errno != EAGAIN && errno != EINTR);
          }
          if (gone) {
            close_client(it);
          } else {
            flush(*it);
          }
          break;
        }
      }
    }
  }
  ::kill(source_pid_, SIGTERM);
  ::waitpid(source_pid_, nullptr, 0);
  ::unlink(o_.socket_path.c_str());
  log_ << "guideway-linuxcnc-bridge: " << counters_.periods << " periods, " << counters_.lost_overrun
       << " lost to halsampler overruns, " << counters_.lost_to_clients << " dropped for slow clients, "
       << counters_.bad_lines << " bad lines, " << counters_.clients << " clients\n"
       << std::flush;
  counters = counters_;
  return 0;
}

void Bridge::accept_clients() {
  while (true) {
    Fd fd(::accept4(listener_.get(), nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK));
    if (fd.get() < 0) return;
    ++counters_.clients;
    Client c;
    c.fd = std::move(fd);
    c.queue = header_;
    clients_.push_back(std::move(c));
    watch(clients_.back().fd.get(), EPOLLIN | EPOLLRDHUP);
    log_ << "guideway-linuxcnc-bridge: client " << counters_.clients << " connected (" << clients_.size()
         << " now)\n"
         << std::flush;
    flush(clients_.back());
  }
}

bool Bridge::read_source() {
  char buf[65536];
  while (true) {
    const ssize_t n = ::read(source_.get(), buf, sizeof(buf));
    if (n == 0) {
      log_ << "guideway-linuxcnc-bridge: the source ended (LinuxCNC stopped?)\n";
      return false;
    }
    if (n < 0) return errno == EAGAIN || errno == EINTR;
    std::string_view bytes(buf, static_cast<std::size_t>(n));
    while (!bytes.empty()) {
      const auto nl = bytes.find('\n');
      if (nl == std::string_view::npos) {
        partial_.append(bytes);
        break;
      }
      partial_.append(bytes.substr(0, nl));
      source_line(partial_);
      partial_.clear();
      bytes.remove_prefix(nl + 1);
    }
    for (auto& c : clients_) flush(c);
  }
}

void Bridge::source_line(std::string_view line) {
  if (line.find("overrun") != std::string_view::npos) {
    overrun_seen_ = true;  // halsampler: the FIFO was full; the next number says how many periods it lost
    return;
  }
  std::int64_t seq = 0;
  std::string why;
  if (!parse_period_line(line, values_.size(), seq, values_, why)) {
    if (++counters_.bad_lines <= 5)
      log_ << "guideway-linuxcnc-bridge: not a period of " << values_.size() << " values (" << why << "): \""
           << line.substr(0, 120) << "\"\n";
    return;
  }
  if (have_seq_) {
    const std::int64_t step = seq_step(last_seq_, seq);
    if (step > 1 && step < (std::int64_t{1} << 31)) {
      const auto gap = static_cast<std::uint64_t>(step - 1);
      counters_.lost_overrun += gap;
      broadcast("! lost " + std::to_string(gap) + (overrun_seen_ ? " halsampler overrun" : " sample numbers skipped") +
                    "\n",
                false);
    }
  }
  overrun_seen_ = false;
  have_seq_ = true;
  last_seq_ = seq;
  ++counters_.periods;
  std::string out(line);
  out += '\n';
  broadcast(out, true);
}

void Bridge::broadcast(const std::string& line, bool is_period) {
  for (auto& c : clients_) {
    if (c.queue.size() + line.size() > o_.client_queue_bytes) {
      if (is_period) {
        ++c.dropped;
        ++counters_.lost_to_clients;
      }
      continue;
    }
    if (c.dropped > 0 && c.queue.size() < o_.client_queue_bytes / 2) {
      c.queue += "! lost " + std::to_string(c.dropped) + " client too slow\n";
      c.dropped = 0;
    }
    c.queue += line;
  }
}

void Bridge::flush(Client& c) {
  while (!c.queue.empty()) {
    const ssize_t n = ::send(c.fd.get(), c.queue.data(), c.queue.size(), MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EAGAIN) break;
      c.queue.clear();  // the client went away: closed at its hang-up
      return;
    }
    c.queue.erase(0, static_cast<std::size_t>(n));
  }
  const bool want = !c.queue.empty();
  if (want != c.writable_armed) {
    watch(c.fd.get(), EPOLLIN | EPOLLRDHUP | (want ? EPOLLOUT : 0u), EPOLL_CTL_MOD);
    c.writable_armed = want;
  }
}

void Bridge::close_client(std::list<Client>::iterator it) {
  ::epoll_ctl(epoll_.get(), EPOLL_CTL_DEL, it->fd.get(), nullptr);
  clients_.erase(it);
  log_ << "guideway-linuxcnc-bridge: a client left (" << clients_.size() << " now)\n" << std::flush;
}

}  // namespace

int run_bridge(const BridgeOptions& options, std::ostream& log, BridgeCounters* counters) {
  Bridge bridge(options, log);
  BridgeCounters c;
  const int rc = bridge.run(c);
  if (counters) *counters = c;
  return rc;
}

}  // namespace guideway::drivers::linuxcnc
