#include "core/runtime_paths.hpp"

#include <unistd.h>

#include <cstdlib>

namespace guideway {

namespace {

std::string env_or_empty(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::string(v) : std::string();
}

// systemd passes a colon-separated list when a unit names several directories; the first is ours.
std::string first_of_list(const std::string& list) { return list.substr(0, list.find(':')); }

std::string per_user_runtime_dir() {
  const std::string xdg = env_or_empty("XDG_RUNTIME_DIR");
  if (!xdg.empty()) return xdg + "/guideway";
  return "/tmp/guideway-" + std::to_string(getuid());
}

}  // namespace

std::string default_socket_path() {
  const std::string runtime = env_or_empty("RUNTIME_DIRECTORY");
  if (!runtime.empty()) return first_of_list(runtime) + "/guideway.sock";
  return per_user_runtime_dir() + "/guideway.sock";
}

std::string default_state_dir() {
  const std::string state = env_or_empty("STATE_DIRECTORY");
  if (!state.empty()) return first_of_list(state);
  const std::string xdg = env_or_empty("XDG_STATE_HOME");
  if (!xdg.empty()) return xdg + "/guideway";
  const std::string home = env_or_empty("HOME");
  if (!home.empty()) return home + "/.local/state/guideway";
  return per_user_runtime_dir() + "/state";
}

std::vector<std::string> client_socket_candidates() {
  std::vector<std::string> out;
  const std::string env = env_or_empty("GUIDEWAY_SOCKET");
  if (!env.empty()) out.push_back(env);
  out.push_back(per_user_runtime_dir() + "/guideway.sock");
  out.emplace_back(system_socket_path);
  return out;
}

}  // namespace guideway
