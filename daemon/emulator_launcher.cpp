#include "daemon/emulator_launcher.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "core/mono_clock.hpp"

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
    : name_(spec.name) {
  int out[2];
  if (pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("pipe: " + std::string(std::strerror(errno)));
  std::vector<std::string> argv_s = {executable, spec.instrument};
  argv_s.insert(argv_s.end(), spec.args.begin(), spec.args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t parent = getpid();
  pid_ = fork();
  if (pid_ < 0) throw std::runtime_error("fork: " + std::string(std::strerror(errno)));
  if (pid_ == 0) {
    prctl(PR_SET_PDEATHSIG, SIGTERM);
    if (getppid() != parent) _exit(1);  // the daemon died before prctl took effect
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);  // the daemon blocks SIGTERM for its signalfd
    dup2(out[1], STDOUT_FILENO);
    dup2(out[1], STDERR_FILENO);
    execvp(argv[0], argv.data());
    const std::string msg = "cannot run " + executable + ": " + std::strerror(errno) + "\n";
    [[maybe_unused]] auto ignored = write(STDOUT_FILENO, msg.data(), msg.size());
    _exit(127);
  }
  close(out[1]);
  stdout_fd_ = out[0];
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
}

bool EmulatorProcess::alive() const {
  if (pid_ <= 0) return false;
  char buf[4096];
  while (read(stdout_fd_, buf, sizeof(buf)) > 0) {
  }
  return waitpid(pid_, nullptr, WNOHANG) == 0;
}

void substitute_emulator_endpoints(toml::table& table, const std::vector<const EmulatorProcess*>& emulators) {
  auto visit = [&](auto& self, toml::node& node) -> void {
    if (auto* s = node.as_string()) {
      const std::string& v = s->get();
      if (v.rfind("emulator:", 0) != 0) return;
      const std::string name = v.substr(9);
      for (const auto* e : emulators) {
        if (e->name() == name) {
          *s = e->endpoint();
          return;
        }
      }
      throw std::invalid_argument("\"" + v + "\" names no [[emulator]] (known: " + [&] {
        std::string known;
        for (const auto* e : emulators) known += (known.empty() ? "" : ", ") + e->name();
        return known.empty() ? std::string("none") : known;
      }() + ")");
    } else if (auto* t = node.as_table()) {
      for (auto&& [k, child] : *t) self(self, child);
    } else if (auto* a = node.as_array()) {
      for (auto& child : *a) self(self, child);
    }
  };
  for (auto&& [k, child] : table) visit(visit, child);
}

}  // namespace guideway::daemon
