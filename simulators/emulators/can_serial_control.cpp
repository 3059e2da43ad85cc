// The fault-injection control channel of the CAN and serial emulator processes (can_serial_control.hpp): one command a
// line.
#include "simulators/emulators/can_serial_control.hpp"

#include <poll.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <sstream>

namespace guideway::simulators::emulators {

void block_stop_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
}

bool word_to_int(const std::vector<std::string>& words, std::size_t i, int& out) {
  if (i >= words.size()) return false;
  try {
    std::size_t used = 0;
    out = std::stoi(words[i], &used);
    return used == words[i].size();
  } catch (const std::exception&) {
    return false;
  }
}

bool word_to_u32(const std::vector<std::string>& words, std::size_t i, std::uint32_t& out) {
  if (i >= words.size() || words[i].empty() || words[i][0] == '-') return false;
  try {
    std::size_t used = 0;
    const unsigned long long v = std::stoull(words[i], &used, 0);
    if (used != words[i].size() || v > 0xFFFFFFFFull) return false;
    out = static_cast<std::uint32_t>(v);
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

bool word_to_double(const std::vector<std::string>& words, std::size_t i, double& out) {
  if (i >= words.size()) return false;
  try {
    std::size_t used = 0;
    out = std::stod(words[i], &used);
    return used == words[i].size();
  } catch (const std::exception&) {
    return false;
  }
}

int run_control_loop(const ControlHandler& handle, double duration_s) {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  const int sfd = signalfd(-1, &set, SFD_CLOEXEC);
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(static_cast<long>(duration_s > 0 ? duration_s * 1000 : 0));
  bool stdin_open = true;
  std::string buffer;
  for (;;) {
    int timeout_ms = -1;
    if (duration_s > 0) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) break;
      timeout_ms = static_cast<int>(left.count());
    }
    pollfd fds[2] = {{sfd, POLLIN, 0}, {stdin_open ? 0 : -1, POLLIN, 0}};
    const int r = ::poll(fds, 2, timeout_ms);
    if (r < 0) continue;
    if (fds[0].revents & POLLIN) break;
    if (fds[1].revents & (POLLIN | POLLHUP)) {
      char chunk[512];
      const ssize_t n = ::read(0, chunk, sizeof chunk);
      if (n <= 0) {
        stdin_open = false;
        continue;
      }
      buffer.append(chunk, static_cast<std::size_t>(n));
      std::size_t eol;
      while ((eol = buffer.find('\n')) != std::string::npos) {
        std::istringstream line(buffer.substr(0, eol));
        buffer.erase(0, eol + 1);
        std::vector<std::string> words;
        for (std::string w; line >> w;) words.push_back(w);
        if (words.empty()) continue;
        if (words[0] == "quit") {
          std::printf("ok quit\n");
          std::fflush(stdout);
          ::close(sfd);
          return 0;
        }
        std::string message;
        const bool ok = handle(words, message);
        std::printf("%s %s%s%s\n", ok ? "ok" : "error", words[0].c_str(), message.empty() ? "" : ": ", message.c_str());
        std::fflush(stdout);
      }
    }
  }
  ::close(sfd);
  return 0;
}

}  // namespace guideway::simulators::emulators
