#pragma once
// Where the daemon's socket and state live when the configuration does not say.
// Under systemd: $RUNTIME_DIRECTORY / $STATE_DIRECTORY (set by RuntimeDirectory=/StateDirectory=).
// Otherwise per user: $XDG_RUNTIME_DIR/guideway, else /tmp/guideway-$UID; $XDG_STATE_HOME/guideway,
// else ~/.local/state/guideway.

#include <string>
#include <vector>

namespace guideway {

inline constexpr const char* system_socket_path = "/run/guideway/guideway.sock";

std::string default_socket_path();
std::string default_state_dir();
// The paths a client tries, in order: $GUIDEWAY_SOCKET, the per-user path, the system path.
std::vector<std::string> client_socket_candidates();

}  // namespace guideway
