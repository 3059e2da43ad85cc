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

// The directory that holds the daemon's socket and lock: created 0700 when missing; an existing one must
// be a real directory (not a symlink) owned by this user (or root), and not writable by others unless
// sticky (as /tmp): otherwise another local user could have made it to serve a fake daemon or to swap
// the socket. Throws std::runtime_error saying what is wrong and what to do.
void secure_socket_directory(const std::string& dir);
// A socket a client is about to trust: owned by this user or root (the system daemon). Throws
// std::runtime_error naming the owner.
void check_socket_owner(const std::string& path);
// Why `path` cannot be a Unix socket's address (sun_path holds 107 bytes and a NUL), or "" when it can.
std::string socket_path_problem(const std::string& path);
// Why this process could not make and write the directory `dir` ("" when it could): it exists and is
// not a writable directory, or its nearest existing parent is not. Creates nothing (--check-config).
std::string directory_creation_problem(const std::string& dir);

}  // namespace guideway
