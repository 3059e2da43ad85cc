#pragma once
// Starts device emulators (`guideway-emulate <instrument> ...`) as child processes for the
// configuration's [[emulator]] tables, so the daemon runs with no hardware. Each emulator prints
// `endpoint: <address>` on stdout once it serves (tcp:HOST:PORT, unix:PATH, pty:PATH); device tables
// then refer to it in any string value: "emulator:NAME" is replaced by the whole address,
// "emulator:NAME:host" / ":path" by that part (a string), "emulator:NAME:port" by the port (an integer).
// The children die with the daemon (PR_SET_PDEATHSIG) and are terminated by the destructor. Their standard
// input is the daemon's (command()): an emulated machine is told what a session asks of it (the DBB
// emulator's circles at the session's feed: emulated_machine_command).

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

namespace guideway::daemon {

struct EmulatorSpec {
  std::string name;
  std::string instrument;
  std::vector<std::string> args;
  std::uint32_t line = 0;  // of its [[emulator]] table, for errors
};

class EmulatorProcess {
 public:
  // Starts the emulator and waits for its endpoint line. Throws std::runtime_error with the
  // emulator's own output when it exits or stays silent past the timeout.
  EmulatorProcess(const std::string& executable, const EmulatorSpec& spec,
                  std::chrono::milliseconds timeout = std::chrono::seconds(10));
  ~EmulatorProcess();
  EmulatorProcess(const EmulatorProcess&) = delete;
  EmulatorProcess& operator=(const EmulatorProcess&) = delete;

  [[nodiscard]] const std::string& name() const noexcept { return name_; }
  [[nodiscard]] const std::string& endpoint() const noexcept { return endpoint_; }
  [[nodiscard]] pid_t pid() const noexcept { return pid_; }
  [[nodiscard]] const std::string& executable() const noexcept { return executable_; }
  [[nodiscard]] const EmulatorSpec& spec() const noexcept { return spec_; }
  [[nodiscard]] bool alive() const;
  // Reaps the child if it has exited (no zombie is left): how it ended ("exit status 1", "killed by
  // signal 9"), or "" while it runs.
  std::string reap();
  // The spec that starts it again at the endpoint it serves (a port it was given as 0 made fixed).
  [[nodiscard]] EmulatorSpec restart_spec() const;
  // Writes one control line (`guideway-emulate`'s stdin commands) without blocking; false when the child
  // is gone or its input is full. Its answer goes to its output, which is drained and dropped.
  bool command(const std::string& line);

 private:
  std::string name_;
  std::string executable_;
  EmulatorSpec spec_;
  std::string endpoint_;
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  int stdin_fd_ = -1;  // our end of the socket pair that is its standard input
};

// guideway-emulate next to the running executable (installed layout or build tree), else on PATH.
std::string default_emulator_executable();

// What an emulator of `instrument` serving a device is told when a session of `session_kind` starts on it
// with these (valid) options; "" when nothing. A DBB session's circles at its feed_mm_per_min (none for 0,
// any feed) and, when the session gives radius_mm, at that radius: `circle FEED_MM_MIN [RADIUS_MM]`.
std::string emulated_machine_command(const std::string& instrument, const std::string& session_kind,
                                     const nlohmann::json& options);

// Replaces every string value "emulator:NAME[:FIELD]" in `table` (recursively) as described above, and
// returns the NAMEs referred to (each once, in the order met): the emulators that serve the device.
// Throws ConfigError at the reference's own line (in `file`, key `key_prefix`.KEY) for a NAME that no
// emulator has, or a FIELD its endpoint lacks.
std::vector<std::string> substitute_emulator_endpoints(toml::table& table, const std::vector<const EmulatorProcess*>& emulators,
                                   const std::string& file = "<config>", const std::string& key_prefix = "");

}  // namespace guideway::daemon
