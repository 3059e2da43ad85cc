#pragma once
// Helpers shared by the session kinds. Options: reading a start request's options (a JSON object);
// unknown keys, wrong types and values out of range are refused with std::invalid_argument naming the
// option, so the client learns at once what is wrong. Derived files: writing a session's text.

#include <initializer_list>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "results/session_kinds.hpp"

namespace guideway::sessions {

// Throws when `options` is not an object or has a key that is not one of the kind's options (the message
// lists them, results/session_kinds.hpp).
void check_option_names(const nlohmann::json& options, const results::SessionKindInfo& kind);
// The number at `key`, `fallback` when absent; it must lie in [min, max].
double number_option(const nlohmann::json& options, const char* key, double fallback, double min, double max);
// A whole number in [min, max].
long long integer_option(const nlohmann::json& options, const char* key, long long fallback, long long min,
                         long long max);
// A string among `allowed` (any string when `allowed` is empty).
std::string string_option(const nlohmann::json& options, const char* key, const std::string& fallback,
                          std::initializer_list<const char*> allowed = {});
// The option as its entry in the kind's table says: default, range, choices.
double number_option(const nlohmann::json& options, const results::SessionOption& option);
long long integer_option(const nlohmann::json& options, const results::SessionOption& option);
std::string string_option(const nlohmann::json& options, const results::SessionOption& option);

// Writes `text` to DIR/BASE.SUFFIX and returns the path ({} when text is empty). Throws
// std::runtime_error naming the path when it cannot be written.
std::vector<std::string> write_derived_text(const std::string& dir, const std::string& base_name,
                                            const std::string& suffix, const std::string& text);

}  // namespace guideway::sessions
