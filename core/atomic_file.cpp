#include "core/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace guideway {

void write_file_atomically(const std::string& path, std::string_view content, std::optional<mode_t> exact_mode) {
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
  if (std::rename(part.c_str(), path.c_str()) != 0) fail("rename failed", errno);
}

}  // namespace guideway
