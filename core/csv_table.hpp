#pragma once
// Reader for Guideway's text tables (docs/formats.md) and plain number columns, shared by every offline
// analysis command: `# key = value` metadata lines (before or after the data; other `#` lines are comments),
// an optional header row of column names, then data rows; or simply one number per line. Cells keep their file
// line so errors read "file:line: message". Pure functions; thread safe.
//
// - Delimiter: ',' (else tab, else ';', else blanks), decided on the first non-comment line.
// - Header: the first non-comment line is a header when one of its cells is not a number; without a header the
//   columns are called "value" (one column) or "column1", "column2", ...
// - Blank lines are skipped; CR-LF line ends and a UTF-8 byte-order mark are accepted; cells are trimmed.
// - Every data row must have as many cells as the header (empty cells are kept as empty strings).
// - A table keeps its text and where each row is, and cuts a row into cells when they are asked for:
//   memory is the file's size and 24 bytes a row (core/input_file.hpp bounds both).

#include <cstddef>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "core/input_file.hpp"

namespace guideway {

struct CsvTable {
  struct Row {
    std::size_t line = 0;  // 1-based line number in the file
    std::size_t begin = 0, end = 0;  // the row's text in the table's text (trimmed)
  };
  std::string source;  // file name used in messages
  std::map<std::string, std::string> metadata;
  std::map<std::string, std::size_t> metadata_line;  // the line each metadata key was last given on
  std::vector<std::string> columns;
  std::size_t header_line = 0;  // 0: no header row in the file (generated column names)
  std::vector<Row> rows;

  [[nodiscard]] std::size_t row_count() const { return rows.size(); }
  // The row's cell `col` (trimmed; "" for an empty cell).
  [[nodiscard]] std::string_view cell(const Row& row, std::size_t col) const;
  // Index of a column or nullopt.
  [[nodiscard]] std::optional<std::size_t> find_column(std::string_view name) const;
  // Index of a required column; throws CsvError naming the file and listing the columns.
  [[nodiscard]] std::size_t column(std::string_view name) const;
  // The cell as a finite double; throws CsvError "file:line: column 'c': 'text' is not a number".
  [[nodiscard]] double number(const Row& row, std::size_t col) const;
  // A whole column as finite doubles (throws on the first bad cell, naming its line).
  [[nodiscard]] std::vector<double> numbers(std::size_t col) const;
  [[nodiscard]] std::vector<double> numbers(std::string_view name) const { return numbers(column(name)); }
  // The column a one-signal command should use: `name` if given, else the only column; throws CsvError listing
  // the columns when there are several and no name.
  [[nodiscard]] std::size_t select_column(const std::optional<std::string>& name) const;
  // Required / optional numeric metadata; throws CsvError naming the key (and its line) when absent or not a number.
  [[nodiscard]] double metadata_number(const std::string& key) const;
  [[nodiscard]] std::optional<double> optional_metadata_number(const std::string& key) const;
  // The same within a plausible range [lo, hi] (docs/formats.md): outside, a CsvError
  // "file:line: key = v is outside [lo, hi] WHAT" (`what`: the unit and why, "mm, a plate's diameter").
  [[nodiscard]] double number_in(const Row& row, std::size_t col, double lo, double hi, std::string_view what) const;
  [[nodiscard]] double metadata_in(const std::string& key, double lo, double hi, std::string_view what) const;
  [[nodiscard]] std::optional<double> optional_metadata_in(const std::string& key, double lo, double hi,
                                                           std::string_view what) const;

  std::string text;  // the file's text, which rows point into
  char delimiter = ',';
};

// Parses `text` (the content of a file called `source`; the table keeps a copy). Throws CsvError, also
// past the row limit (core/input_file.hpp).
[[nodiscard]] CsvTable parse_csv_table(std::string_view text, const std::string& source);
// Reads (read_text_file: a regular file within the limits) and parses a file ("-" reads standard input).
// Throws CsvError (also when the file cannot be read).
[[nodiscard]] CsvTable read_csv_table(const std::string& path);
// Parses a finite double from the whole of `text` (surrounding blanks allowed); nullopt otherwise.
[[nodiscard]] std::optional<double> parse_double(std::string_view text);

}  // namespace guideway
