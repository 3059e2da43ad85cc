#pragma once
// A blocking JSON Lines client of guidewayd (for the CLI, tests and tools). Not thread safe.

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "results/message_class.hpp"

namespace guideway::cli {

class DaemonClient {
 public:
  // Connects to a Unix socket path, or "tcp:HOST:PORT". Throws std::runtime_error with the reason.
  explicit DaemonClient(const std::string& address);
  // Tries each candidate (see client_socket_candidates) and reports every failure if none answers.
  static DaemonClient connect_first(const std::vector<std::string>& candidates);
  ~DaemonClient();
  DaemonClient(DaemonClient&& other) noexcept;
  DaemonClient& operator=(DaemonClient&&) = delete;
  DaemonClient(const DaemonClient&) = delete;
  DaemonClient& operator=(const DaemonClient&) = delete;

  void send_line(const std::string& line);
  void send(const nlohmann::json& request) { send_line(request.dump()); }
  // Next line from the daemon; nullopt on timeout. Throws when the connection closes.
  std::optional<std::string> read_line(std::chrono::milliseconds timeout);
  // Sends a request and returns the first reply whose class is `reply_class` or ERROR, skipping
  // published messages in between. Throws on timeout.
  nlohmann::json request(const nlohmann::json& request, results::MessageClass reply_class,
                         std::chrono::milliseconds timeout = std::chrono::seconds(5));
  [[nodiscard]] const nlohmann::json& banner() const noexcept { return banner_; }
  [[nodiscard]] const std::string& address() const noexcept { return address_; }

 private:
  int fd_ = -1;
  std::string address_;
  std::string buffer_;
  nlohmann::json banner_;
};

// The daemon at `address` (a path or tcp:HOST:PORT), or when it is empty the first default
// candidate that answers (client_socket_candidates). Throws std::runtime_error naming every failure.
DaemonClient connect_daemon(const std::string& address);
// Throws std::runtime_error "daemon: MESSAGE" when `reply` is an ERROR message.
void throw_if_error(const nlohmann::json& reply);

}  // namespace guideway::cli
