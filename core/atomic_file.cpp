// Whole files written so that a reader never sees half of one (atomic_file.hpp).
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
  const auto previous_of = [&](const std::string& name) { return path_of(name) + ".previous"; };
  const auto remove_parts = [&] {
    for (const auto& f : files) std::remove((path_of(f.name) + ".part").c_str());
  };
  for (std::size_t i = 0; i < files.size(); ++i) {
    try {
      write_part(path_of(files[i].name), files[i].content, std::nullopt);
    } catch (...) {
      for (std::size_t k = 0; k < i; ++k) std::remove((path_of(files[k].name) + ".part").c_str());
      throw;
    }
  }
  // The earlier set is kept aside first: its files of the new set's names as hard links NAME.previous
  // (they stay in place), the retired ones moved to NAME.previous (out of the way of the new set). Should
  // a rename of the new set then fail half way, everything is put back: the earlier set whole, or the
  // new one, never a mix (the renames are one at a time, a set is not).
  struct Kept {
    std::string name;
    bool moved;  // retired: moved aside (else linked)
  };
  std::vector<Kept> kept;
  const auto restore = [&](std::size_t committed) {
    for (std::size_t k = 0; k < committed; ++k) {
      const std::string& name = files[k].name;
      const bool had = std::any_of(kept.begin(), kept.end(), [&](const Kept& x) { return x.name == name; });
      if (had)
        std::rename(previous_of(name).c_str(), path_of(name).c_str());
      else
        std::remove(path_of(name).c_str());
    }
    for (const Kept& x : kept) {
      if (x.moved) std::rename(previous_of(x.name).c_str(), path_of(x.name).c_str());
      else std::remove(previous_of(x.name).c_str());  // a link of a file that was not replaced
    }
  };
  const auto fail = [&](const std::string& what, int err, std::size_t committed) {
    const std::string why = what + ": " + std::strerror(err);
    restore(committed);
    remove_parts();
    throw std::runtime_error(why + " (the earlier set is left as it was)");
  };
  const auto exists = [](const std::string& path) {
    struct stat st {};
    return ::lstat(path.c_str(), &st) == 0;
  };
  for (const auto& f : files) {
    if (!exists(path_of(f.name))) continue;
    std::remove(previous_of(f.name).c_str());  // a crash's leftover
    if (::link(path_of(f.name).c_str(), previous_of(f.name).c_str()) != 0)
      fail(path_of(f.name) + ": cannot keep the earlier file aside", errno, 0);
    kept.push_back({f.name, false});
  }
  for (const auto& name : retired) {
    const bool in_set = std::any_of(files.begin(), files.end(), [&](const NamedContent& f) { return f.name == name; });
    if (in_set || !exists(path_of(name))) continue;
    std::remove(previous_of(name).c_str());
    if (std::rename(path_of(name).c_str(), previous_of(name).c_str()) != 0)
      fail(path_of(name) + ": cannot move the previous set's file aside", errno, 0);
    kept.push_back({name, true});
  }
  for (std::size_t i = 0; i < files.size(); ++i) {  // renames need no space
    const std::string part = path_of(files[i].name) + ".part";
    if (std::rename(part.c_str(), path_of(files[i].name).c_str()) != 0)
      fail(part + ": rename failed", errno, i);
  }
  for (const Kept& x : kept) std::remove(previous_of(x.name).c_str());  // the new set is whole
}

}  // namespace guideway
