// Device emulators as child processes (emulator_launcher.hpp): started, their endpoints read, put into device tables.
#include "daemon/emulator_launcher.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <optional>
#include <variant>
#include <stdexcept>

#include "core/mono_clock.hpp"
#include "core/toml_access.hpp"
#include "results/session_kinds.hpp"

namespace guideway::daemon {

namespace {

constexpr std::string_view endpoint_prefix = "endpoint: ";

}  // namespace

std::string default_emulator_executable() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto dir = exe.parent_path();
    for (const auto& candidate : {dir / "guideway-emulate", dir.parent_path() / "simulators" / "emulators" / "guideway-emulate",
                                  dir.parent_path() / "bin" / "guideway-emulate"}) {
      if (std::filesystem::exists(candidate, ec)) return candidate.string();
    }
  }
  return "guideway-emulate";  // execvp searches PATH
}

EmulatorProcess::EmulatorProcess(const std::string& executable, const EmulatorSpec& spec,
                                 std::chrono::milliseconds timeout)
    : name_(spec.name), executable_(executable), spec_(spec) {
  int out[2];
  if (pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("pipe: " + std::string(std::strerror(errno)));
  // Its standard input: a socket, so that a write to an emulator that died fails (MSG_NOSIGNAL) instead of
  // raising SIGPIPE in whoever holds a launcher.
  int in[2];
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, in) != 0) {
    const int err = errno;
    close(out[0]);
    close(out[1]);
    throw std::runtime_error("socketpair: " + std::string(std::strerror(err)));
  }
  std::vector<std::string> argv_s = {executable, spec.instrument};
  argv_s.insert(argv_s.end(), spec.args.begin(), spec.args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t parent = getpid();
  pid_ = fork();
  if (pid_ < 0) {
    const int err = errno;
    for (const int fd : {out[0], out[1], in[0], in[1]}) close(fd);
    throw std::runtime_error("fork: " + std::string(std::strerror(err)));
  }
  if (pid_ == 0) {
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(1);  // the daemon died before prctl took effect
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);  // the daemon blocks SIGTERM for its signalfd
    // Emulators take commands on stdin: launched ones the daemon's (command()), not its terminal's.
    dup2(in[1], STDIN_FILENO);
    dup2(out[1], STDOUT_FILENO);
    dup2(out[1], STDERR_FILENO);
    execvp(argv[0], argv.data());
    const std::string msg = "cannot run " + executable + ": " + std::strerror(errno) + "\n";
    [[maybe_unused]] auto ignored = write(STDOUT_FILENO, msg.data(), msg.size());
    _exit(127);
  }
  close(out[1]);
  close(in[1]);
  stdout_fd_ = out[0];
  stdin_fd_ = in[0];
  std::string output;
  const std::int64_t deadline = mono_now_ns() + timeout.count() * 1'000'000;
  for (;;) {
    if (auto pos = output.find(endpoint_prefix); pos != std::string::npos) {
      const auto nl = output.find('\n', pos);
      if (nl != std::string::npos) {
        endpoint_ = output.substr(pos + endpoint_prefix.size(), nl - pos - endpoint_prefix.size());
        break;
      }
    }
    const std::int64_t left_ms = (deadline - mono_now_ns()) / 1'000'000;
    pollfd p{stdout_fd_, POLLIN, 0};
    const int r = left_ms > 0 ? poll(&p, 1, static_cast<int>(left_ms)) : 0;
    char buf[4096];
    const ssize_t n = r > 0 ? read(stdout_fd_, buf, sizeof(buf)) : -1;
    if (n > 0) {
      output.append(buf, static_cast<std::size_t>(n));
      continue;
    }
    if (r < 0 && errno == EINTR) continue;
    kill(pid_, SIGTERM);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
    close(stdout_fd_);
    close(stdin_fd_);
    throw std::runtime_error("emulator " + spec.name + " (" + executable + " " + spec.instrument + ") " +
                             (r == 0 || left_ms <= 0 ? "printed no endpoint within the timeout" : "exited") +
                             (output.empty() ? "" : "; it said: " + output));
  }
  // Keep draining its output so the child never blocks on a full pipe.
  fcntl(stdout_fd_, F_SETFL, O_NONBLOCK);
}

EmulatorProcess::~EmulatorProcess() {
  if (pid_ > 0) {
    kill(pid_, SIGTERM);
    for (int i = 0; i < 100; ++i) {
      if (waitpid(pid_, nullptr, WNOHANG) == pid_) {
        pid_ = -1;
        break;
      }
      usleep(10'000);
    }
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  if (stdout_fd_ >= 0) close(stdout_fd_);
  if (stdin_fd_ >= 0) close(stdin_fd_);
}

bool EmulatorProcess::command(const std::string& line) {
  if (pid_ <= 0 || stdin_fd_ < 0) return false;
  const std::string text = line + "\n";
  const ssize_t n = ::send(stdin_fd_, text.data(), text.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  return n == static_cast<ssize_t>(text.size());
}

std::string emulated_machine_command(const std::string& instrument, const std::string& session_kind,
                                     const nlohmann::json& options) {
  if (instrument != "dbb" || session_kind != results::dbb_kind.name || !options.is_object()) return "";
  const auto number = [&](const results::SessionOption& o) -> std::optional<double> {
    const auto it = options.find(std::string(o.name));
    if (it == options.end()) return std::nullopt;
    if (!it->is_number()) return std::nullopt;
    return it->get<double>();
  };
  const double feed_mm_min = number(results::dbb_feed_mm_per_min).value_or(results::dbb_feed_mm_per_min.fallback);
  if (!(feed_mm_min > 0)) return "";  // 0: the session takes any feed
  std::ostringstream out;
  out << "circle " << feed_mm_min;
  if (const auto r = number(results::dbb_radius_mm); r && *r > 0) out << " " << *r;
  return out.str();
}

std::string EmulatorProcess::reap() {
  if (pid_ <= 0) return "";
  char buf[4096];
  while (read(stdout_fd_, buf, sizeof(buf)) > 0) {
  }
  int status = 0;
  if (waitpid(pid_, &status, WNOHANG) != pid_) return "";
  pid_ = -1;
  if (WIFEXITED(status)) return "exit status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return "killed by signal " + std::to_string(WTERMSIG(status));
  return "ended";
}

EmulatorSpec EmulatorProcess::restart_spec() const {
  EmulatorSpec s = spec_;
  // tcp:HOST:PORT: a listening port asked for as 0 ("HOST:0", or "--port 0") is the one it got, so the
  // devices configured with that endpoint find it again.
  if (endpoint_.rfind("tcp:", 0) != 0) return s;
  const auto colon = endpoint_.rfind(':');
  const std::string host = endpoint_.substr(4, colon - 4), port = endpoint_.substr(colon + 1);
  for (std::size_t i = 0; i < s.args.size(); ++i) {
    if (s.args[i] == host + ":0") s.args[i] = host + ":" + port;
    if (s.args[i] == "0" && i > 0 && s.args[i - 1] == "--port") s.args[i] = port;
  }
  return s;
}

bool EmulatorProcess::alive() const {
  if (pid_ <= 0) return false;
  char buf[4096];
  while (read(stdout_fd_, buf, sizeof(buf)) > 0) {
  }
  return waitpid(pid_, nullptr, WNOHANG) == 0;
}

namespace {

// "tcp:HOST:PORT", "unix:PATH", "pty:PATH" (or a bare path) -> the requested field as a TOML value.
std::variant<std::string, std::int64_t> endpoint_field(const std::string& endpoint, const std::string& field,
                                                      const std::string& ref) {
  if (field.empty()) return endpoint;
  const auto colon = endpoint.find(':');
  const std::string scheme = colon == std::string::npos ? "" : endpoint.substr(0, colon);
  const std::string rest = colon == std::string::npos ? endpoint : endpoint.substr(colon + 1);
  if (scheme == "tcp" || scheme == "udp") {
    const auto last = rest.rfind(':');
    if (field == "host") return rest.substr(0, last);
    if (field == "port") {
      try {
        return static_cast<std::int64_t>(std::stoll(rest.substr(last + 1)));
      } catch (const std::exception&) {
        throw std::invalid_argument("\"" + ref + "\": endpoint " + endpoint + " has no port");
      }
    }
  }
  if (field == "path") return rest;
  throw std::invalid_argument("\"" + ref + "\": no field \"" + field + "\" in endpoint " + endpoint +
                              " (fields: host, port for tcp:HOST:PORT; path for unix:PATH, pty:PATH)");
}

}  // namespace

std::vector<std::string> substitute_emulator_endpoints(toml::table& table,
                                                       const std::vector<const EmulatorProcess*>& emulators,
                                                       const std::string& file, const std::string& key_prefix) {
  std::vector<std::string> referred;
  // Returns the replacement for a string value "emulator:NAME[:FIELD]", or nothing.
  auto replacement = [&](const std::string& v) -> std::optional<std::variant<std::string, std::int64_t>> {
    if (v.rfind("emulator:", 0) != 0) return std::nullopt;
    const std::string ref = v.substr(9);
    const auto colon = ref.find(':');
    const std::string name = ref.substr(0, colon);
    const std::string field = colon == std::string::npos ? "" : ref.substr(colon + 1);
    for (const auto* e : emulators) {
      if (e->name() != name) continue;
      if (std::find(referred.begin(), referred.end(), name) == referred.end()) referred.push_back(name);
      return endpoint_field(e->endpoint(), field, v);
    }
    std::string known;
    for (const auto* e : emulators) known += (known.empty() ? "" : ", ") + e->name();
    throw std::invalid_argument("\"" + v + "\" names no [[emulator]] (known: " + (known.empty() ? "none" : known) + ")");
  };
  auto visit_table = [&](auto& self, toml::table& t, const std::string& prefix) -> void {
    std::vector<std::pair<std::string, std::int64_t>> integers;  // re-typed after the walk
    for (auto&& [k, child] : t) {
      const std::string key = prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
      if (auto* str = child.as_string()) {
        std::optional<std::variant<std::string, std::int64_t>> r;
        try {
          r = replacement(str->get());
        } catch (const std::invalid_argument& e) {
          throw ConfigError(file, str->source().begin.line, key, e.what());  // the line of the reference itself
        }
        if (r) {
          if (std::holds_alternative<std::string>(*r)) {
            *str = std::get<std::string>(*r);
          } else {
            integers.emplace_back(std::string(k.str()), std::get<std::int64_t>(*r));
          }
        }
      } else if (auto* sub = child.as_table()) {
        self(self, *sub, key);
      } else if (auto* arr = child.as_array()) {
        std::size_t i = 0;
        for (auto& item : *arr) {
          if (auto* st = item.as_table()) self(self, *st, key + "[" + std::to_string(i) + "]");
          ++i;
        }
      }
    }
    for (const auto& [k, v] : integers) t.insert_or_assign(k, v);
  };
  visit_table(visit_table, table, key_prefix);
  return referred;
}

}  // namespace guideway::daemon
