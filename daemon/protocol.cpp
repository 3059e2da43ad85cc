// guidewayd's JSON Lines protocol (protocol.hpp): requests parsed, errors and subscriptions.
#include "daemon/protocol.hpp"

#include <algorithm>
#include <cctype>
#include <stdexcept>

namespace guideway::daemon {

nlohmann::json version_message() {
  return results::with_class(
      results::MessageClass::version,
      {{"release", GUIDEWAY_VERSION}, {"proto_major", protocol_major}, {"proto_minor", protocol_minor}});
}

nlohmann::json error_message(std::string_view message, std::string_view request_class) {
  nlohmann::json j = results::with_class(results::MessageClass::error, {{"message", message}});
  if (!request_class.empty()) j["request"] = request_class;
  return j;
}

namespace {

// The text of the request's top-level "id" when it is a number JSON holds as a double (not a 64-bit
// integer): read with nlohmann's SAX interface, which hands over a number's lexeme.
class IdLexeme : public nlohmann::json::json_sax_t {
 public:
  std::string lexeme;
  bool null() override { return value(); }
  bool boolean(bool) override { return value(); }
  bool number_integer(number_integer_t) override { return value(); }
  bool number_unsigned(number_unsigned_t) override { return value(); }
  bool number_float(number_float_t, const string_t& s) override {
    if (depth_ == 1 && key_ == "id") lexeme = s;
    return value();
  }
  bool string(string_t&) override { return value(); }
  bool binary(binary_t&) override { return value(); }
  bool start_object(std::size_t) override { return ++depth_, key_.clear(), true; }
  bool key(string_t& k) override {
    if (depth_ == 1) key_ = k;
    return true;
  }
  bool end_object() override { return --depth_, key_.clear(), true; }
  bool start_array(std::size_t) override { return ++depth_, true; }
  bool end_array() override { return --depth_, true; }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override { return false; }

 private:
  bool value() { return true; }
  int depth_ = 0;
  std::string key_;
};

// Significant digits of a JSON number's lexeme (no sign, exponent, leading or trailing zeros).
std::size_t significant_digits(std::string_view lexeme) {
  std::string digits;
  for (char c : lexeme.substr(0, lexeme.find_first_of("eE"))) {
    if (c >= '0' && c <= '9') digits += c;
  }
  const auto a = digits.find_first_not_of('0');
  if (a == std::string::npos) return 0;
  return digits.find_last_not_of('0') - a + 1;
}

// A double holds every decimal of 15 significant digits exactly (DBL_DIG): a number id with more, not a
// 64-bit integer, would come back as another number.
constexpr std::size_t exact_id_digits = 15;

}  // namespace

std::optional<Request> parse_request(std::string_view line, RequestError& error) {
  error = {};
  if (line.find_first_not_of(" \t\r") == std::string_view::npos) {
    error.message = "empty request (one JSON object per line, e.g. {\"class\":\"status\"})";
    return std::nullopt;
  }
  // Refused rather than cut there: what follows a NUL would otherwise pass unseen.
  if (line.find('\0') != std::string_view::npos) {
    error.message = "a request must not contain a NUL byte";
    return std::nullopt;
  }
  nlohmann::json body = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
  if (body.is_discarded()) {
    error.message = "malformed JSON";
    return std::nullopt;
  }
  if (!body.is_object()) {
    error.message = "a request must be a JSON object";
    return std::nullopt;
  }
  Request r;
  if (auto id = body.find("id"); id != body.end()) {
    if (id->is_number_float()) {
      IdLexeme sax;
      (void)nlohmann::json::sax_parse(line, &sax);
      if (significant_digits(sax.lexeme) > exact_id_digits) {
        error.message = "\"id\" " + sax.lexeme.substr(0, 64) +
                        " cannot be echoed exactly: a number id has at most 15 significant digits or is a 64-bit "
                        "integer (send a longer one as a string)";
        return std::nullopt;
      }
    }
    r.id = *id;
  }
  auto cls = body.find("class");
  if (cls == body.end() || !cls->is_string()) {
    error.message = "a request needs a string \"class\" (e.g. {\"class\":\"status\"})";
    error.id = r.id;
    return std::nullopt;
  }
  r.cls = cls->get<std::string>();
  std::transform(r.cls.begin(), r.cls.end(), r.cls.begin(), [](unsigned char c) { return std::tolower(c); });
  r.body = std::move(body);
  return r;
}

bool Subscription::wants(results::MessageClass cls, std::string_view channel, std::string_view session) const {
  if (!enabled) return false;
  if (classes.empty() ? cls == results::MessageClass::sample : !classes.contains(cls)) return false;
  return channels.empty() || channel.empty() || channels.contains(channel) ||
         (!session.empty() && channels.contains(session));
}

namespace {

std::set<std::string, std::less<>> string_set(const nlohmann::json& body, const char* key, bool upper) {
  std::set<std::string, std::less<>> out;
  auto it = body.find(key);
  if (it == body.end()) return out;
  if (!it->is_array()) throw std::invalid_argument(std::string("\"") + key + "\" must be an array of strings");
  for (const auto& v : *it) {
    if (!v.is_string()) throw std::invalid_argument(std::string("\"") + key + "\" must be an array of strings");
    std::string s = v.get<std::string>();
    if (upper) std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::toupper(c); });
    out.insert(std::move(s));
  }
  return out;
}

}  // namespace

nlohmann::json apply_watch(const nlohmann::json& body, Subscription& sub) {
  auto enable = body.find("enable");
  if (enable != body.end() && !enable->is_boolean()) throw std::invalid_argument("\"enable\" must be true or false");
  Subscription next;
  next.enabled = enable == body.end() ? true : enable->get<bool>();
  const auto class_names = string_set(body, "classes", true);
  for (const auto& name : class_names) {
    const auto cls = results::published_class(name);
    if (!cls)
      throw std::invalid_argument("unknown class \"" + name + "\" (published: " + results::published_class_names() +
                                  ")");
    next.classes.insert(*cls);
  }
  next.channels = string_set(body, "channels", false);
  sub = std::move(next);
  nlohmann::json reply = results::with_class(results::MessageClass::watch, {{"enable", sub.enabled}});
  if (!class_names.empty()) reply["classes"] = class_names;
  if (!sub.channels.empty()) reply["channels"] = sub.channels;
  return reply;
}

}  // namespace guideway::daemon
