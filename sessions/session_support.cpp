// What the session kinds share (session_support.hpp): a start request's options checked, derived files' text.
#include "sessions/session_support.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace guideway::sessions {

namespace {

template <class Names>
std::string list(const Names& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + std::string(n);
  return out;
}

// "return|now" -> {"return", "now"}.
std::vector<std::string> choices_of(std::string_view choices) {
  std::vector<std::string> out;
  while (!choices.empty()) {
    const auto bar = choices.find('|');
    out.emplace_back(choices.substr(0, bar));
    choices = bar == std::string_view::npos ? std::string_view() : choices.substr(bar + 1);
  }
  return out;
}

std::string string_among(const nlohmann::json& options, const std::string& key, const std::string& fallback,
                         const std::vector<std::string>& allowed) {
  auto it = options.find(key);
  if (it == options.end()) return fallback;
  if (!it->is_string()) throw std::invalid_argument("option " + key + " must be a string");
  const std::string v = it->get<std::string>();
  if (allowed.empty()) return v;
  for (const auto& a : allowed) {
    if (v == a) return v;
  }
  throw std::invalid_argument("option " + key + " = \"" + v + "\" must be one of: " + list(allowed));
}

}  // namespace

void check_option_names(const nlohmann::json& options, const results::SessionKindInfo& kind) {
  const std::string name(kind.name);
  if (!options.is_object()) throw std::invalid_argument(name + " options must be a JSON object");
  std::vector<std::string_view> known;
  for (const results::SessionOption* o : kind.options) known.push_back(o->name);
  for (const auto& [k, v] : options.items()) {
    bool found = false;
    for (const auto n : known) found = found || k == n;
    if (!found) throw std::invalid_argument("unknown " + name + " option \"" + k + "\" (known: " + list(known) + ")");
  }
}

double number_option(const nlohmann::json& options, const char* key, double fallback, double min, double max) {
  auto it = options.find(key);
  if (it == options.end()) return fallback;
  if (!it->is_number()) throw std::invalid_argument(std::string("option ") + key + " must be a number");
  const double v = it->get<double>();
  if (!(v >= min && v <= max)) {
    std::ostringstream m;
    m << "option " << key << " = " << v << " is outside [" << min << ", " << max << "]";
    throw std::invalid_argument(m.str());
  }
  return v;
}

long long integer_option(const nlohmann::json& options, const char* key, long long fallback, long long min,
                         long long max) {
  auto it = options.find(key);
  if (it == options.end()) return fallback;
  if (!it->is_number() || (it->is_number_float() && std::floor(it->get<double>()) != it->get<double>())) {
    throw std::invalid_argument(std::string("option ") + key + " must be a whole number");
  }
  const double v = it->get<double>();
  if (!(v >= static_cast<double>(min) && v <= static_cast<double>(max))) {
    std::ostringstream m;
    m << "option " << key << " = " << v << " is outside [" << min << ", " << max << "]";
    throw std::invalid_argument(m.str());
  }
  return static_cast<long long>(v);
}

std::string string_option(const nlohmann::json& options, const char* key, const std::string& fallback,
                          std::initializer_list<const char*> allowed) {
  return string_among(options, key, fallback, std::vector<std::string>(allowed.begin(), allowed.end()));
}

double number_option(const nlohmann::json& options, const results::SessionOption& o) {
  return number_option(options, std::string(o.name).c_str(), o.fallback, o.min, o.max);
}

long long integer_option(const nlohmann::json& options, const results::SessionOption& o) {
  return integer_option(options, std::string(o.name).c_str(), static_cast<long long>(o.fallback),
                        static_cast<long long>(o.min), static_cast<long long>(o.max));
}

std::string string_option(const nlohmann::json& options, const results::SessionOption& o) {
  return string_among(options, std::string(o.name), std::string(o.fallback_text), choices_of(o.choices));
}

std::vector<std::string> write_derived_text(const std::string& dir, const std::string& base_name,
                                            const std::string& suffix, const std::string& text) {
  if (text.empty()) return {};
  const std::string path = dir + "/" + base_name + "." + suffix;
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f << text;
  f.close();
  if (!f) {
    const int err = errno;
    std::remove(path.c_str());  // a truncated derived file would read as a (wrong) shorter one
    throw std::runtime_error("cannot write " + path + ": " + std::strerror(err));
  }
  return {path};
}

}  // namespace guideway::sessions
