#pragma once
// Typed, validated access to a TOML table. Every error names the file, the line and the full key,
// e.g. "guideway.toml:12: device[1].baud_rate: expected an integer, got a string".
// Not thread safe (records which keys were read, so unknown keys can be rejected).

#include <cstdint>
#include <limits>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include <toml++/toml.h>

#include "core/utc_time.hpp"

namespace guideway {

class ConfigError : public std::runtime_error {
 public:
  ConfigError(std::string file, std::uint32_t line, std::string key, const std::string& message);
  [[nodiscard]] const std::string& file() const noexcept { return file_; }
  [[nodiscard]] std::uint32_t line() const noexcept { return line_; }
  [[nodiscard]] const std::string& key() const noexcept { return key_; }

 private:
  std::string file_;
  std::uint32_t line_;
  std::string key_;
};

// Parses TOML text; syntax errors become ConfigError with the parser's line.
toml::table parse_toml(std::string_view text, const std::string& file_name);
toml::table parse_toml_file(const std::string& path);

class TableReader {
 public:
  TableReader(const toml::table& table, std::string file, std::string path);

  [[nodiscard]] bool has(std::string_view key) const;
  std::string get_string(std::string_view key, std::string fallback) const;
  std::string require_string(std::string_view key) const;
  std::int64_t get_int(std::string_view key, std::int64_t fallback,
                       std::int64_t min = std::numeric_limits<std::int64_t>::min(),
                       std::int64_t max = std::numeric_limits<std::int64_t>::max()) const;
  std::int64_t require_int(std::string_view key, std::int64_t min = std::numeric_limits<std::int64_t>::min(),
                           std::int64_t max = std::numeric_limits<std::int64_t>::max()) const;
  // Accepts integers too (a user writes `radius_mm = 100`).
  double get_double(std::string_view key, double fallback, double min = -std::numeric_limits<double>::infinity(),
                    double max = std::numeric_limits<double>::infinity()) const;
  double require_double(std::string_view key, double min = -std::numeric_limits<double>::infinity(),
                        double max = std::numeric_limits<double>::infinity()) const;
  bool get_bool(std::string_view key, bool fallback) const;
  std::vector<double> get_doubles(std::string_view key, std::vector<double> fallback) const;
  std::vector<std::string> get_strings(std::string_view key, std::vector<std::string> fallback) const;
  // A date: a TOML local date (calibrated_on = 2025-03-14) or the same as a string ("2025-03-14");
  // nullopt when the key is absent. A date that does not exist, or any other value, is an error.
  std::optional<CalendarDate> get_date(std::string_view key) const;
  // One of the allowed words, e.g. direction = "ccw" | "cw".
  std::string get_choice(std::string_view key, std::string fallback, const std::vector<std::string>& allowed) const;

  std::optional<TableReader> table(std::string_view key) const;
  std::vector<TableReader> tables(std::string_view key) const;  // [[key]] array of tables

  // Throws on the first key present in the table that no getter asked for (catches typos).
  void reject_unknown_keys() const;

  [[noreturn]] void fail(std::string_view key, const std::string& message) const;
  [[nodiscard]] const std::string& path() const noexcept { return path_; }
  [[nodiscard]] const std::string& file() const noexcept { return file_; }
  [[nodiscard]] const toml::table& raw() const noexcept { return *table_; }

 private:
  const toml::node* lookup(std::string_view key) const;
  std::string full_key(std::string_view key) const;
  [[noreturn]] void fail_at(const toml::node* node, std::string_view key, const std::string& message) const;

  const toml::table* table_;
  std::string file_;
  std::string path_;
  mutable std::set<std::string, std::less<>> read_keys_;
};

}  // namespace guideway
