// Typed, validated access to a TOML table (toml_access.hpp): every error names file, line and key.
#include "core/toml_access.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/input_file.hpp"

namespace guideway {

namespace {

std::string type_word(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::array: return "an array";
    case toml::node_type::table: return "a table";
    default: return "a date/time";
  }
}

std::uint32_t line_of(const toml::node* node) { return node ? node->source().begin.line : 0; }

std::string format_message(const std::string& file, std::uint32_t line, const std::string& key,
                           const std::string& message) {
  // Appended piece by piece: GCC 12 at -O3 reports a false -Wrestrict on `":" + std::to_string(line)`.
  std::string out = file;
  if (line != 0) {
    out += ':';
    out += std::to_string(line);
  }
  out += ": ";
  if (!key.empty()) {
    out += key;
    out += ": ";
  }
  out += message;
  return out;
}

}  // namespace

ConfigError::ConfigError(std::string file, std::uint32_t line, std::string key, const std::string& message)
    : std::runtime_error(format_message(file, line, key, message)),
      file_(std::move(file)),
      line_(line),
      key_(std::move(key)) {}

toml::table parse_toml(std::string_view text, const std::string& file_name) {
  try {
    return toml::parse(text, file_name);
  } catch (const toml::parse_error& e) {
    throw ConfigError(file_name, e.source().begin.line, "", std::string(e.description()));
  }
}

toml::table parse_toml_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw ConfigError(path, 0, "", "is a directory, not a configuration file");
  std::string text;
  try {  // a regular file within the input limits: a FIFO or a device is refused, never waited on
    text = read_text_file(path);
  } catch (const CsvError& e) {
    std::string why = e.what();
    if (why.starts_with(path + ": ")) why.erase(0, path.size() + 2);
    throw ConfigError(path, 0, "", why);
  }
  return parse_toml(text, path);
}

TableReader::TableReader(const toml::table& table, std::string file, std::string path)
    : table_(&table), file_(std::move(file)), path_(std::move(path)) {}

std::string TableReader::full_key(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

const toml::node* TableReader::lookup(std::string_view key) const {
  read_keys_.emplace(key);
  return table_->get(key);
}

bool TableReader::has(std::string_view key) const { return table_->contains(key); }

void TableReader::fail_at(const toml::node* node, std::string_view key, const std::string& message) const {
  const std::uint32_t line = node ? line_of(node) : line_of(table_);
  throw ConfigError(file_, line, full_key(key), message);
}

void TableReader::fail(std::string_view key, const std::string& message) const { fail_at(table_->get(key), key, message); }

std::string TableReader::get_string(std::string_view key, std::string fallback) const {
  const toml::node* node = lookup(key);
  if (!node) return fallback;
  if (auto v = node->value<std::string>(); v && node->is_string()) return *v;
  fail_at(node, key, "expected a string, got " + type_word(*node));
}

std::string TableReader::require_string(std::string_view key) const {
  if (!table_->contains(key)) fail_at(nullptr, key, "required key is missing");
  return get_string(key, {});
}

std::int64_t TableReader::get_int(std::string_view key, std::int64_t fallback, std::int64_t min,
                                  std::int64_t max) const {
  const toml::node* node = lookup(key);
  if (!node) return fallback;
  if (!node->is_integer()) fail_at(node, key, "expected an integer, got " + type_word(*node));
  const std::int64_t v = *node->value<std::int64_t>();
  if (v < min || v > max) {
    fail_at(node, key, "value " + std::to_string(v) + " is outside [" + std::to_string(min) + ", " +
                           std::to_string(max) + "]");
  }
  return v;
}

std::int64_t TableReader::require_int(std::string_view key, std::int64_t min, std::int64_t max) const {
  if (!table_->contains(key)) fail_at(nullptr, key, "required key is missing");
  return get_int(key, 0, min, max);
}

double TableReader::get_double(std::string_view key, double fallback, double min, double max) const {
  const toml::node* node = lookup(key);
  if (!node) return fallback;
  if (!node->is_number()) fail_at(node, key, "expected a number, got " + type_word(*node));
  const double v = *node->value<double>();
  if (!(v >= min && v <= max)) {
    std::ostringstream msg;
    msg << "value " << v << " is outside [" << min << ", " << max << "]";
    fail_at(node, key, msg.str());
  }
  return v;
}

double TableReader::require_double(std::string_view key, double min, double max) const {
  if (!table_->contains(key)) fail_at(nullptr, key, "required key is missing");
  return get_double(key, 0.0, min, max);
}

bool TableReader::get_bool(std::string_view key, bool fallback) const {
  const toml::node* node = lookup(key);
  if (!node) return fallback;
  if (!node->is_boolean()) fail_at(node, key, "expected true or false, got " + type_word(*node));
  return *node->value<bool>();
}

std::vector<double> TableReader::get_doubles(std::string_view key, std::vector<double> fallback) const {
  const toml::node* node = lookup(key);
  if (!node) return fallback;
  const toml::array* arr = node->as_array();
  if (!arr) fail_at(node, key, "expected an array of numbers, got " + type_word(*node));
  std::vector<double> out;
  for (const toml::node& item : *arr) {
    if (!item.is_number()) fail_at(&item, key, "expected an array of numbers, found " + type_word(item));
    out.push_back(*item.value<double>());
  }
  return out;
}

std::vector<std::string> TableReader::get_strings(std::string_view key, std::vector<std::string> fallback) const {
  const toml::node* node = lookup(key);
  if (!node) return fallback;
  const toml::array* arr = node->as_array();
  if (!arr) fail_at(node, key, "expected an array of strings, got " + type_word(*node));
  std::vector<std::string> out;
  for (const toml::node& item : *arr) {
    if (!item.is_string()) fail_at(&item, key, "expected an array of strings, found " + type_word(item));
    out.push_back(*item.value<std::string>());
  }
  return out;
}

std::optional<CalendarDate> TableReader::get_date(std::string_view key) const {
  const toml::node* node = lookup(key);
  if (!node) return std::nullopt;
  const char* expected = "expected a date YYYY-MM-DD (a TOML date such as 2025-03-14, or the string \"2025-03-14\")";
  std::string text;
  if (const auto* d = node->as_date()) {
    const toml::date& v = d->get();
    text = to_iso({v.year, v.month, v.day});
  } else if (const auto* str = node->as_string()) {
    text = str->get();
  } else {
    fail_at(node, key, std::string(expected) + ", got " + type_word(*node));
  }
  const std::optional<CalendarDate> date = parse_iso_date(text);
  if (!date) fail_at(node, key, std::string(expected) + ", got \"" + text + "\"");
  return date;
}

std::string TableReader::get_choice(std::string_view key, std::string fallback,
                                    const std::vector<std::string>& allowed) const {
  std::string v = get_string(key, std::move(fallback));
  for (const auto& a : allowed) {
    if (a == v) return v;
  }
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + ("\"" + a + "\"");
  fail_at(table_->get(key), key, "\"" + v + "\" is not one of " + list);
}

std::optional<TableReader> TableReader::table(std::string_view key) const {
  const toml::node* node = lookup(key);
  if (!node) return std::nullopt;
  const toml::table* t = node->as_table();
  if (!t) fail_at(node, key, "expected a table, got " + type_word(*node));
  return TableReader(*t, file_, full_key(key));
}

std::vector<TableReader> TableReader::tables(std::string_view key) const {
  std::vector<TableReader> out;
  const toml::node* node = lookup(key);
  if (!node) return out;
  const toml::array* arr = node->as_array();
  if (!arr) fail_at(node, key, "expected an array of tables ([[" + std::string(key) + "]]), got " + type_word(*node));
  std::size_t i = 0;
  for (const toml::node& item : *arr) {
    const toml::table* t = item.as_table();
    if (!t) fail_at(&item, key, "expected a table in the array, got " + type_word(item));
    out.emplace_back(*t, file_, full_key(key) + "[" + std::to_string(i++) + "]");
  }
  return out;
}

void TableReader::reject_unknown_keys() const {
  for (const auto& [k, node] : *table_) {
    if (!read_keys_.contains(k.str())) {
      throw ConfigError(file_, line_of(&node), full_key(k.str()), "unknown key");
    }
  }
}

}  // namespace guideway
