#pragma once
// Reading a result's JSON field by field (results/explanation.cpp, results/dbb_record.cpp, results/kind_records.cpp):
// every key optional (absent: the default stays), every present one of its type, else a FieldError naming where it
// is ("findings[2]: \"p_value\" is string, expected a number or null"), which each reader rethrows as its own
// error (rethrown_as: ExplanationFormatError, ParamsFormatError). Never another exception on any JSON. And the
// one way those writers write a number that may not be finite (finite_or_null). Internal to results/.

#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace guideway::results::json_fields {

using nlohmann::json;

class FieldError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// `read_it()`, a FieldError it throws rethrown as the reader's own error `Error` (ParamsFormatError, ...).
template <typename Error, typename Read>
auto rethrown_as(Read read_it) {
  try {
    return read_it();
  } catch (const FieldError& e) {
    throw Error(e.what());
  }
}

// `v`, or null when it is not finite (NaN: not computed; an infinite condition number: none).
json finite_or_null(double v);

// Throws FieldError "where: what" ("what" alone at the top level, where is "").
[[noreturn]] void fail(const std::string& where, const std::string& what);

// "where.key", "where[i]": a place in the JSON, for errors.
std::string at(const std::string& where, const char* key);
std::string at(const std::string& where, std::size_t i);

// `j` when it is an object, else a failure naming `where`.
const json& object_at(const json& j, const std::string& where);

[[nodiscard]] bool is_number_or_null(const json& v);
[[nodiscard]] double number_of(const json& v);  // a number, or NaN for null
[[nodiscard]] bool is_count(const json& v);     // a whole number, 0 or more

// `o[key]` when present (nullptr when absent); of a type `accepts` takes, else a failure naming the key and
// what was `expected`.
const json* field(const json& o, const std::string& where, const char* key, const char* expected,
                  bool (*accepts)(const json&));
const json* array_field(const json& o, const std::string& where, const char* key);
const json* object_field(const json& o, const std::string& where, const char* key);

void read(const json& o, const std::string& where, const char* key, double& out);  // null: NaN
void read(const json& o, const std::string& where, const char* key, std::optional<double>& out);  // absent: none
void read(const json& o, const std::string& where, const char* key, std::string& out);
void read(const json& o, const std::string& where, const char* key, bool& out);
void read(const json& o, const std::string& where, const char* key, std::size_t& out);
void read(const json& o, const std::string& where, const char* key, std::pair<double, double>& out);
void read(const json& o, const std::string& where, const char* key, std::vector<double>& out);
void read(const json& o, const std::string& where, const char* key, std::vector<std::string>& out);

// A struct's number under its key: the one list that the struct's writer and its reader both go through.
template <typename T>
struct NumberField {
  const char* key;
  double T::*member;
};

template <typename T, std::size_t N>
void write_numbers(json& j, const T& t, const NumberField<T> (&fields)[N]) {
  for (const NumberField<T>& f : fields) j[f.key] = t.*f.member;
}

template <typename T, std::size_t N>
void read_numbers(const json& o, const std::string& where, T& t, const NumberField<T> (&fields)[N]) {
  for (const NumberField<T>& f : fields) read(o, where, f.key, t.*f.member);
}

// The numbers (or nulls: NaN) of the array `a` at `where`.
std::vector<double> numbers_at(const json& a, const std::string& where);

// Each element of the array at `o[key]`, an object, read by `read_one(element, its place)`.
template <typename T, typename ReadOne>
void read_objects(const json& o, const std::string& where, const char* key, std::vector<T>& out, ReadOne read_one) {
  const json* a = array_field(o, where, key);
  if (a == nullptr) return;
  out.clear();
  for (std::size_t i = 0; i < a->size(); ++i) {
    const std::string place = at(at(where, key), i);
    out.push_back(read_one(object_at((*a)[i], place), place));
  }
}

// Each member of the object at `o[key]`, an object, read by `read_one(member, its place)` into `out[its name]`.
template <typename Map, typename ReadOne>
void read_named(const json& o, const std::string& where, const char* key, Map& out, ReadOne read_one) {
  const json* v = object_field(o, where, key);
  if (v == nullptr) return;
  out.clear();
  for (const auto& [member, value] : v->items()) {
    const std::string place = at(where, key) + "." + member;
    out.emplace(member, read_one(object_at(value, place), place));
  }
}

}  // namespace guideway::results::json_fields
