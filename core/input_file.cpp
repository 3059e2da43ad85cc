// Every file an offline command reads, read here (input_file.hpp): regular files only, within bounds.
#include "core/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>

#include "core/number_format.hpp"

namespace guideway {

namespace {

std::atomic<std::uint64_t> max_bytes{InputLimits{}.max_bytes};
std::atomic<std::uint64_t> max_rows{InputLimits{}.max_rows};

std::string what_it_is(mode_t mode) {
  if (S_ISDIR(mode)) return "is a directory";
  if (S_ISFIFO(mode)) return "is a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "is a character device";
  if (S_ISBLK(mode)) return "is a block device";
  if (S_ISSOCK(mode)) return "is a socket";
  return "is not a regular file";
}

std::string bytes_text(std::uint64_t bytes) {
  return bytes >= 1'000'000 ? printf_number("%.4g MB", static_cast<double>(bytes) * 1e-6)
                            : std::to_string(bytes) + " bytes";
}

std::string over_bytes(const std::string& path, const std::string& size) {
  return path + ": " + size + " is over the limit of " + bytes_text(max_bytes.load()) +
         " a file (guideway --max-input-mb)";
}

// The file open for reading, checked to be a regular file within the bound; its size in `size`.
// O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer before the check could say no.
int open_checked(const std::string& path, std::uint64_t& size) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) throw CsvError(path + ": cannot read (" + std::strerror(errno) + ")");
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int e = errno;
    ::close(fd);
    throw CsvError(path + ": cannot read (" + std::strerror(e) + ")");
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    throw CsvError(path + ": " + what_it_is(st.st_mode) + ", not a regular file: only files are read");
  }
  size = static_cast<std::uint64_t>(st.st_size);
  if (size > max_bytes.load()) {
    ::close(fd);
    throw CsvError(over_bytes(path, bytes_text(size)));
  }
  return fd;
}

// Reads `fd` to its end or to `limit` bytes (a file that grows while it is read is cut there and
// `over` is set when more was left).
std::string read_fd(int fd, const std::string& path, std::uint64_t limit, std::uint64_t size_hint, bool& over) {
  std::string out;
  out.reserve(static_cast<std::size_t>(std::min(size_hint, limit)));
  over = false;
  char buf[1 << 16];
  while (true) {
    const ssize_t n = ::read(fd, buf, sizeof(buf));
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN) {  // standard input open non-blocking by whoever gave it: wait for it
        ::usleep(1000);
        continue;
      }
      throw CsvError(path + ": read error (" + std::strerror(errno) + ")");
    }
    if (n == 0) break;
    const std::uint64_t room = limit - out.size();
    if (static_cast<std::uint64_t>(n) > room) {
      out.append(buf, static_cast<std::size_t>(room));
      over = true;
      break;
    }
    out.append(buf, static_cast<std::size_t>(n));
  }
  return out;
}

}  // namespace

void set_input_limits(const InputLimits& limits) noexcept {
  max_bytes = limits.max_bytes;
  max_rows = limits.max_rows;
}

InputLimits input_limits() noexcept { return {max_bytes.load(), max_rows.load()}; }

std::string read_text_file(const std::string& path) {
  bool over = false;
  if (path == "-") {
    std::string text = read_fd(STDIN_FILENO, "<stdin>", max_bytes.load(), 0, over);
    if (over) throw CsvError(over_bytes("<stdin>", "more"));
    return text;
  }
  std::uint64_t size = 0;
  const int fd = open_checked(path, size);
  try {
    std::string text = read_fd(fd, path, max_bytes.load(), size, over);
    ::close(fd);
    if (over) throw CsvError(over_bytes(path, "more (it grew while it was read)"));
    return text;
  } catch (...) {
    ::close(fd);
    throw;
  }
}

std::string read_file_head(const std::string& path, std::size_t bytes) {
  std::uint64_t size = 0;
  const int fd = open_checked(path, size);
  bool over = false;
  try {
    std::string text = read_fd(fd, path, bytes, std::min<std::uint64_t>(size, bytes), over);
    ::close(fd);
    return text;
  } catch (...) {
    ::close(fd);
    throw;
  }
}

void check_row_count(std::uint64_t rows, const std::string& source, std::size_t line) {
  if (rows <= max_rows.load()) return;
  throw CsvError(source + ":" + std::to_string(line) + ": more than " + std::to_string(max_rows.load()) +
                 " data rows, the limit a table (guideway --max-input-rows)");
}

}  // namespace guideway
