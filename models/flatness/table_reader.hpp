#pragma once
// Minimal reader for Guideway CSV files with a `# key = value` metadata header (docs/formats.md):
// metadata lines, one header row of column names, data rows, optional `#` trailer lines. Every cell
// keeps its file line number so that callers can report "file:line: message". Pure functions; thread
// safe.
//
// TODO(core/csv_table): replace with the shared core/csv_table reader once it is committed; only the
// flatness-specific validation belongs in this module.

#include <cstddef>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace guideway::models {

// A user-facing input error; what() is "file:line: message" (or "file: message").
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One parsed CSV file: metadata (verbatim strings), column names, rows of raw cells.
struct TableFile {
  struct Row {
    std::size_t line = 0;  // 1-based line number in the file
    std::vector<std::string> cells;
  };
  std::string source;  // file name used in messages
  std::map<std::string, std::string> metadata;
  std::vector<std::string> columns;
  std::size_t header_line = 0;
  std::vector<Row> rows;

  // Index of a column or nullopt.
  [[nodiscard]] std::optional<std::size_t> find_column(std::string_view name) const;
  // Index of a required column; throws InputError naming the file and the header line.
  [[nodiscard]] std::size_t column(std::string_view name) const;
  // The cell as a finite double; throws InputError "file:line: column 'c': 'text' is not a number".
  [[nodiscard]] double number(const Row& row, std::size_t col) const;
  // Required / optional numeric metadata; throws InputError naming the key when absent or not a number.
  [[nodiscard]] double metadata_number(const std::string& key) const;
  [[nodiscard]] std::optional<double> optional_metadata_number(const std::string& key) const;
};

// Parses `text` (the content of a file called `source`). Throws InputError.
TableFile parse_table(std::string_view text, const std::string& source);
// Reads and parses a file. Throws InputError (also when the file cannot be read).
TableFile read_table(const std::string& path);
// Reads a whole text file; throws InputError "path: cannot read (reason)".
std::string read_text_file(const std::string& path);
// Parses a finite double from the whole of `text` (surrounding blanks allowed); nullopt otherwise.
std::optional<double> parse_double(std::string_view text);

}  // namespace guideway::models
