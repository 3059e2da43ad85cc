// The daemon's default socket and state paths (runtime_paths.hpp).
#include "core/runtime_paths.hpp"

#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>

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

void secure_socket_directory(const std::string& dir) {
  if (dir.empty()) return;
  struct stat st {};
  if (::lstat(dir.c_str(), &st) != 0) {
    if (errno != ENOENT) throw std::runtime_error(dir + ": " + std::strerror(errno));
    std::error_code ec;
    const auto parent = std::filesystem::path(dir).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent, ec);
    if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST)
      throw std::runtime_error("cannot create socket directory " + dir + ": " + std::strerror(errno));
    if (::lstat(dir.c_str(), &st) != 0) throw std::runtime_error(dir + ": " + std::strerror(errno));
  }
  const auto refuse = [&](const std::string& why) {
    throw std::runtime_error("refusing socket directory " + dir + ": " + why +
                             "; another local user could serve a fake daemon there or replace the socket. Remove it, "
                             "or give a directory of your own (XDG_RUNTIME_DIR, --socket)");
  };
  if (S_ISLNK(st.st_mode)) refuse("it is a symbolic link");
  if (!S_ISDIR(st.st_mode)) refuse("it is not a directory");
  if (st.st_uid != ::getuid() && st.st_uid != 0) refuse("it belongs to uid " + std::to_string(st.st_uid) + ", not you");
  if ((st.st_mode & S_IWOTH) != 0 && (st.st_mode & S_ISVTX) == 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    refuse(std::string("anyone can write to it (mode ") + mode + ")");
  }
}

void check_socket_owner(const std::string& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) return;  // connect() says what is missing
  if (st.st_uid != ::getuid() && st.st_uid != 0)
    throw std::runtime_error(path + ": refusing a socket owned by uid " + std::to_string(st.st_uid) +
                             " (neither you nor root): it may not be your daemon");
}

std::string socket_path_problem(const std::string& path) {
  constexpr std::size_t room = sizeof(sockaddr_un{}.sun_path) - 1;
  if (path.empty()) return "empty socket path";
  if (path.size() > room)
    return "socket path is " + std::to_string(path.size()) + " bytes; a Unix socket's address holds at most " +
           std::to_string(room) + ": choose a shorter path";
  return "";
}

std::string directory_creation_problem(const std::string& dir) {
  std::filesystem::path p = std::filesystem::absolute(dir).lexically_normal();
  bool missing = false;
  for (;;) {
    struct stat st {};
    if (stat(p.c_str(), &st) == 0) {
      if (!S_ISDIR(st.st_mode))
        return missing ? "cannot be created: " + p.string() + " is not a directory" : "is not a directory";
      if (access(p.c_str(), W_OK | X_OK) != 0)
        return missing ? "cannot be created: " + p.string() + " is not writable (" + std::strerror(errno) + ")"
                       : "is not writable (" + std::string(std::strerror(errno)) + ")";
      return {};
    }
    if (errno != ENOENT) return "cannot be reached: " + p.string() + ": " + std::strerror(errno);
    if (!p.has_parent_path() || p.parent_path() == p) return "cannot be created: no existing parent";
    missing = true;
    p = p.parent_path();
  }
}

}  // namespace guideway
