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

std::string list(std::initializer_list<const char*> names) {
  std::string out;
  for (const char* n : names) out += (out.empty() ? "" : ", ") + std::string(n);
  return out;
}

}  // namespace

void check_option_names(const nlohmann::json& options, const std::string& kind,
                        std::initializer_list<const char*> known) {
  if (!options.is_object()) throw std::invalid_argument(kind + " options must be a JSON object");
  for (const auto& [k, v] : options.items()) {
    bool found = false;
    for (const char* n : known) found = found || k == n;
    if (!found) throw std::invalid_argument("unknown " + kind + " option \"" + k + "\" (known: " + list(known) + ")");
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
  auto it = options.find(key);
  if (it == options.end()) return fallback;
  if (!it->is_string()) throw std::invalid_argument(std::string("option ") + key + " must be a string");
  const std::string v = it->get<std::string>();
  if (allowed.size() == 0) return v;
  for (const char* a : allowed) {
    if (v == a) return v;
  }
  throw std::invalid_argument(std::string("option ") + key + " = \"" + v + "\" must be one of: " + list(allowed));
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

nlohmann::json explain_not_analysed(const std::string& model, const std::string& reason) {
  return {{"model", model}, {"not_analysed", reason}, {"findings", nlohmann::json::array()}, {"unexplained", true},
          {"notes", nlohmann::json::array({"not analysed: " + reason})}};
}

}  // namespace guideway::sessions
