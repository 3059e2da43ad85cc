#pragma once
// Every file an offline command reads (and the daemon's configuration) is read here: only a regular file
// (a FIFO would hang the reader, /dev/zero or a device fill memory), at most InputLimits::max_bytes of it,
// and the rows of a table counted against InputLimits::max_rows, so memory stays in proportion to what
// was read; every error names the file (docs/formats.md, "Limits"). The limits are set once, by the
// command line, before any file is read; reading is thread safe.

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace guideway {

struct InputLimits {
  std::uint64_t max_bytes = 2'000'000'000;  // 2 GB a file (guideway --max-input-mb)
  std::uint64_t max_rows = 50'000'000;      // 50 M data rows a table (guideway --max-input-rows)
};
void set_input_limits(const InputLimits& limits) noexcept;
[[nodiscard]] InputLimits input_limits() noexcept;

// A user-facing input error; what() is "file:line: message" (or "file: message").
class CsvError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Reads a whole file ("-": standard input, which may be a pipe, bounded all the same). Throws CsvError
// naming `path`: cannot be read, not a regular file (says what it is), over max_bytes.
[[nodiscard]] std::string read_text_file(const std::string& path);
// At most the first `bytes` bytes of `path`, with the same checks: enough to see its format line.
[[nodiscard]] std::string read_file_head(const std::string& path, std::size_t bytes);
// Throws CsvError "source:line: more than N rows" when `rows` is past max_rows (a reader calls it as it
// counts, so a table over the bound stops there, not at its end).
void check_row_count(std::uint64_t rows, const std::string& source, std::size_t line);

}  // namespace guideway
