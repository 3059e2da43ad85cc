#include "core/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace guideway {

namespace {

// Writes PATH.part whole; throws (the part removed) when it cannot.
void write_part(const std::string& path, std::string_view content, std::optional<mode_t> exact_mode) {
  const std::string part = path + ".part";
  const auto fail = [&](const std::string& what, int err) {
    std::remove(part.c_str());
    throw std::runtime_error(part + ": " + what + ": " + std::strerror(err));
  };
  const int fd = ::open(part.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, exact_mode.value_or(0666));
  if (fd < 0) fail("cannot open for writing", errno);
  if (exact_mode) ::fchmod(fd, *exact_mode);  // the umask, or an older part file's mode, would stay
  std::size_t done = 0;
  while (done < content.size()) {
    const ssize_t n = ::write(fd, content.data() + done, content.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(fd);
      fail("write failed", err);
    }
    done += static_cast<std::size_t>(n);
  }
  if (::close(fd) != 0) fail("write failed", errno);
}

void commit_part(const std::string& path) {
  const std::string part = path + ".part";
  if (std::rename(part.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(part.c_str());
    throw std::runtime_error(part + ": rename failed: " + std::strerror(err));
  }
}

}  // namespace

void write_file_atomically(const std::string& path, std::string_view content, std::optional<mode_t> exact_mode) {
  write_part(path, content, exact_mode);
  commit_part(path);
}

void write_file_set_atomically(const std::string& dir, const std::vector<NamedContent>& files,
                               const std::vector<std::string>& retired) {
  const auto path_of = [&](const std::string& name) { return dir + "/" + name; };
  for (std::size_t i = 0; i < files.size(); ++i) {
    try {
      write_part(path_of(files[i].name), files[i].content, std::nullopt);
    } catch (...) {
      for (std::size_t k = 0; k < i; ++k) std::remove((path_of(files[k].name) + ".part").c_str());
      throw;
    }
  }
  for (const auto& f : files) commit_part(path_of(f.name));  // renames need no space
  for (const auto& name : retired) {
    const bool in_set = std::any_of(files.begin(), files.end(), [&](const NamedContent& f) { return f.name == name; });
    if (!in_set && std::remove(path_of(name).c_str()) != 0 && errno != ENOENT)
      throw std::runtime_error(path_of(name) + ": cannot remove the previous set's file: " + std::strerror(errno));
  }
}

}  // namespace guideway
