// A result's JSON read field by field (json_fields.hpp): the one set of readers the results' types use.
#include "results/json_fields.hpp"

#include <cmath>
#include <limits>

namespace guideway::results::json_fields {

json finite_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

void fail(const std::string& where, const std::string& what) {
  throw FieldError(where.empty() ? what : where + ": " + what);
}

std::string at(const std::string& where, const char* key) { return where.empty() ? key : where + "." + key; }
std::string at(const std::string& where, std::size_t i) { return where + "[" + std::to_string(i) + "]"; }

const json& object_at(const json& j, const std::string& where) {
  if (!j.is_object()) fail("", where + " is " + j.type_name() + ", expected an object");
  return j;
}

bool is_number_or_null(const json& v) { return v.is_number() || v.is_null(); }
double number_of(const json& v) { return v.is_null() ? std::numeric_limits<double>::quiet_NaN() : v.get<double>(); }
bool is_count(const json& v) { return v.is_number_unsigned() || (v.is_number_integer() && v.get<long long>() >= 0); }

const json* field(const json& o, const std::string& where, const char* key, const char* expected,
                  bool (*accepts)(const json&)) {
  const auto it = o.find(key);
  if (it == o.end()) return nullptr;
  if (!accepts(*it)) fail(where, "\"" + std::string(key) + "\" is " + it->type_name() + ", expected " + expected);
  return &*it;
}

const json* array_field(const json& o, const std::string& where, const char* key) {
  return field(o, where, key, "an array", [](const json& e) { return e.is_array(); });
}

const json* object_field(const json& o, const std::string& where, const char* key) {
  return field(o, where, key, "an object", [](const json& e) { return e.is_object(); });
}

void read(const json& o, const std::string& where, const char* key, double& out) {
  if (const json* v = field(o, where, key, "a number or null", is_number_or_null)) out = number_of(*v);
}
void read(const json& o, const std::string& where, const char* key, std::optional<double>& out) {
  if (const json* v = field(o, where, key, "a number or null", is_number_or_null)) out = number_of(*v);
}
void read(const json& o, const std::string& where, const char* key, std::string& out) {
  if (const json* v = field(o, where, key, "a text", [](const json& e) { return e.is_string(); }))
    out = v->get<std::string>();
}
void read(const json& o, const std::string& where, const char* key, bool& out) {
  if (const json* v = field(o, where, key, "true or false", [](const json& e) { return e.is_boolean(); }))
    out = v->get<bool>();
}
void read(const json& o, const std::string& where, const char* key, std::size_t& out) {
  if (const json* v = field(o, where, key, "a whole number, 0 or more", is_count)) out = v->get<std::size_t>();
}

void read(const json& o, const std::string& where, const char* key, std::pair<double, double>& out) {
  const json* a = array_field(o, where, key);
  if (a == nullptr) return;
  if (a->size() != 2 || !is_number_or_null((*a)[0]) || !is_number_or_null((*a)[1]))
    fail(where, "\"" + std::string(key) + "\" must be two numbers (or nulls)");
  out = {number_of((*a)[0]), number_of((*a)[1])};
}

std::vector<double> numbers_at(const json& a, const std::string& where) {
  if (!a.is_array()) fail("", where + " is " + a.type_name() + ", expected an array");
  std::vector<double> out;
  out.reserve(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!is_number_or_null(a[i])) fail("", at(where, i) + " is " + a[i].type_name() + ", expected a number or null");
    out.push_back(number_of(a[i]));
  }
  return out;
}

void read(const json& o, const std::string& where, const char* key, std::vector<double>& out) {
  if (const json* a = array_field(o, where, key)) out = numbers_at(*a, at(where, key));
}

void read(const json& o, const std::string& where, const char* key, std::vector<std::string>& out) {
  const json* a = array_field(o, where, key);
  if (a == nullptr) return;
  out.clear();
  for (std::size_t i = 0; i < a->size(); ++i) {
    if (!(*a)[i].is_string()) fail("", at(at(where, key), i) + " is " + (*a)[i].type_name() + ", expected a text");
    out.push_back((*a)[i].get<std::string>());
  }
}

}  // namespace guideway::results::json_fields
