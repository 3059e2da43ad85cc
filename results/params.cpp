// PARAMS' JSON (params.hpp), written and read: the one place its figures' keys are spelled.
#include "results/params.hpp"

#include <utility>

#include "results/result_header.hpp"

namespace guideway::results {

namespace {

using nlohmann::json;

[[noreturn]] void fail(const std::string& what) { throw ParamsFormatError(what); }

json figure_json(const Figure& f) {
  json j = {{"value", f.value}};  // NaN: null
  if (f.u) j["u"] = *f.u;
  if (!f.not_determined.empty()) j["not_determined"] = f.not_determined;
  return j;
}

// An object of figures: each member an object with "value", and besides it only "u" and "not_determined".
bool is_figure_group(const json& v) {
  if (!v.is_object()) return false;
  for (const auto& [name, f] : v.items()) {
    if (!f.is_object() || !f.contains("value")) return false;
    for (const auto& [key, ignored] : f.items())
      if (key != "value" && key != "u" && key != "not_determined") return false;
  }
  return true;
}

// A number, or NaN for null; anything else is refused, naming where it is.
double number_or_null(const json& v, const std::string& where, const char* key) {
  if (v.is_number()) return v.get<double>();
  if (v.is_null()) return params_nan;
  fail(where + ": \"" + key + "\" is " + v.type_name() + ", expected a number or null");
}

FigureGroup group_from(const std::string& name, const json& v) {
  FigureGroup g{name, {}};
  for (const auto& [figure_name, f] : v.items()) {
    const std::string where = name + "." + figure_name;
    Figure out{figure_name,
               number_or_null(f.at("value"), where, "value"),
               std::nullopt,
               {},
               find_parameter(figure_name, name)};
    if (const auto u = f.find("u"); u != f.end()) out.u = number_or_null(*u, where, "u");
    if (const auto why = f.find("not_determined"); why != f.end()) {
      if (!why->is_string()) fail(where + ": \"not_determined\" is " + why->type_name() + ", expected a text");
      out.not_determined = why->get<std::string>();
    }
    g.figures.push_back(std::move(out));
  }
  return g;
}

// The typed texts and their keys, written and read from this one list.
constexpr std::pair<const char*, std::string Params::*> text_fields[] = {
    {"model", &Params::model}, {"plane", &Params::plane},           {"axis", &Params::axis},
    {"test", &Params::test},   {"incomplete", &Params::incomplete},
};

std::string* text_field(Params& p, std::string_view key) {
  for (const auto& [name, member] : text_fields)
    if (key == name) return &(p.*member);
  return nullptr;
}

}  // namespace

const Figure* FigureGroup::find(std::string_view figure_name) const {
  for (const Figure& f : figures)
    if (f.name == figure_name) return &f;
  return nullptr;
}

const FigureGroup* Params::group(std::string_view name) const {
  for (const FigureGroup& g : groups)
    if (g.name == name) return &g;
  return nullptr;
}

const Figure* Params::find(std::string_view group_name, std::string_view name) const {
  const FigureGroup* g = group(group_name);
  return g == nullptr ? nullptr : g->find(name);
}

FigureGroup& Params::group_named(std::string_view name) {
  for (FigureGroup& g : groups)
    if (g.name == name) return g;
  return groups.emplace_back(FigureGroup{std::string(name), {}});
}

Figure figure(std::string name, double value, std::optional<double> u, std::string_view group) {
  const Parameter* entry = find_parameter(name, group);
  return Figure{std::move(name), value, u, {}, entry};
}

json to_json(const Params& p) {
  json j = p.record.is_object() ? p.record : json::object();
  for (const auto& [key, member] : text_fields)
    if (!(p.*member).empty()) j[key] = p.*member;
  for (const FigureGroup& g : p.groups) {
    json o = json::object();
    for (const Figure& f : g.figures) o[f.name] = figure_json(f);
    j[g.name] = std::move(o);
  }
  return j;
}

Params params_from_json(const json& j) {
  if (!j.is_object()) fail(std::string("a PARAMS is an object, not ") + j.type_name());
  Params p;
  for (const auto& [key, v] : j.items()) {
    if (is_header_key(key)) continue;
    if (std::string* text = text_field(p, key)) {
      if (!v.is_string()) fail("\"" + key + "\" is " + v.type_name() + ", expected a text");
      *text = v.get<std::string>();
    } else if (is_figure_group(v)) {
      p.groups.push_back(group_from(key, v));
    } else {
      p.record[key] = v;
    }
  }
  return p;
}

}  // namespace guideway::results
