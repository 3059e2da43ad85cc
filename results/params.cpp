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

// PARAMS' "planes" (planes_json). A plane's PARAMS holds no planes of its own: what comes from a broker does not
// nest without end.
std::map<std::string, PlaneParams> planes_from(const json& v) {
  if (!v.is_object()) fail(std::string("\"planes\" is ") + v.type_name() + ", expected an object");
  std::map<std::string, PlaneParams> out;
  for (const auto& [plane, entry] : v.items()) {
    const std::string where = "planes." + plane;
    if (!entry.is_object()) fail(where + " is " + entry.type_name() + ", expected an object");
    if (const auto error = entry.find("error"); error != entry.end()) {
      if (!error->is_string()) fail(where + ": \"error\" is " + error->type_name() + ", expected a text");
      out[plane].error = error->get<std::string>();
    } else if (entry.contains("planes")) {
      fail(where + ": a plane's PARAMS holds no planes of its own");
    } else {
      try {
        out[plane].params = std::make_shared<const Params>(params_from_json(entry));
      } catch (const ParamsFormatError& e) {
        fail(where + ": " + e.what());
      }
    }
  }
  return out;
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
  if (p.dbb) {
    json dbb = to_json(*p.dbb);
    for (auto it = dbb.begin(); it != dbb.end(); ++it) j[it.key()] = std::move(it.value());
  }
  if (p.revolution) j[std::string(revolution_key)] = to_json(*p.revolution);
  if (p.runout_result) j[std::string(result_key)] = to_json(*p.runout_result);
  if (p.traverse) j[std::string(traverse_key)] = to_json(*p.traverse);
  if (p.traverse_result) j[std::string(result_key)] = to_json(*p.traverse_result);
  if (p.wavelet) j[std::string(wavelet_key)] = to_json(*p.wavelet);
  if (p.points) j[std::string(points_key)] = to_json(*p.points);
  if (p.profile_id) j[std::string(profile_id_key)] = profile_id_json(*p.profile_id);
  if (!p.planes.empty()) j["planes"] = planes_json(p.planes);
  for (const auto& [key, member] : text_fields)
    if (!(p.*member).empty()) j[key] = p.*member;
  for (const FigureGroup& g : p.groups) {
    json o = json::object();
    for (const Figure& f : g.figures) o[f.name] = figure_json(f);
    j[g.name] = std::move(o);
  }
  return j;
}

json planes_json(const std::map<std::string, PlaneParams>& planes) {
  json j = json::object();
  for (const auto& [plane, entry] : planes)
    j[plane] = entry.params ? to_json(*entry.params) : json{{"error", entry.error}};
  return j;
}

Params params_from_json(const json& j) {
  if (!j.is_object()) fail(std::string("a PARAMS is an object, not ") + j.type_name());
  Params p;
  json dbb = json::object();
  for (const auto& [key, v] : j.items()) {
    if (is_header_key(key)) continue;
    if (std::string* text = text_field(p, key)) {
      if (!v.is_string()) fail("\"" + key + "\" is " + v.type_name() + ", expected a text");
      *text = v.get<std::string>();
    } else if (is_dbb_record_key(key)) {
      dbb[key] = v;
    } else if (key == revolution_key) {
      p.revolution = revolution_from_json(v);
    } else if (key == result_key && result_model(v) == runout_model) {
      p.runout_result = runout_result_from_json(v);
    } else if (key == result_key && result_model(v) == traverse_model) {
      p.traverse_result = traverse_result_from_json(v);
    } else if (key == traverse_key) {
      p.traverse = traverse_setup_from_json(v);
    } else if (key == wavelet_key) {
      p.wavelet = wavelet_from_json(v);
    } else if (key == points_key) {
      p.points = points_from_json(v);
    } else if (key == profile_id_key) {
      p.profile_id = profile_id_from_json(v);
    } else if (key == "planes") {
      p.planes = planes_from(v);
    } else if (is_figure_group(v)) {
      p.groups.push_back(group_from(key, v));
    } else {
      p.record[key] = v;
    }
  }
  if (!dbb.empty()) p.dbb = dbb_record_from_json(dbb);
  return p;
}

}  // namespace guideway::results
