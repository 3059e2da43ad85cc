// A DBB identification's record as JSON (dbb_record.hpp), written and read: the one place its keys are spelled.
#include "results/dbb_record.hpp"

#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "results/json_fields.hpp"
#include "results/parameters.hpp"
#include "results/params.hpp"

namespace guideway::results {

namespace {

using nlohmann::json;
using namespace json_fields;

constexpr std::string_view record_keys[] = {"runs", "ranking",         "ranking_model", "notes",
                                            "fit",  "diagnostics_fit", "standards",     "summary"};

// The standards' figures, each under its catalogue name as {"value": v}.
struct RunFigure {
  const Parameter* entry;
  double DbbStandardRun::*value;
};
constexpr RunFigure run_figures[] = {{&iso_circular_deviation, &DbbStandardRun::iso_circular_deviation_um},
                                     {&iso_radial_deviation_max, &DbbStandardRun::iso_radial_deviation_max_um},
                                     {&iso_radial_deviation_min, &DbbStandardRun::iso_radial_deviation_min_um},
                                     {&asme_circularity, &DbbStandardRun::asme_circularity_um}};
struct PairFigure {
  const Parameter* entry;
  double DbbStandardPair::*value;
};
constexpr PairFigure pair_figures[] = {
    {&iso_circular_hysteresis, &DbbStandardPair::iso_circular_hysteresis_um},
    {&iso_bidirectional_deviation, &DbbStandardPair::iso_bidirectional_deviation_um},
    {&asme_hysteresis, &DbbStandardPair::asme_hysteresis_um},
    {&asme_bidirectional_circularity, &DbbStandardPair::asme_bidirectional_circularity_um}};

constexpr const char* not_recorded = "not recorded";

// ---- writing ---------------------------------------------------------------------------------------------

json estimate_json(const DbbEstimate& e) {
  json j = {{"value", e.value}};
  if (e.u) j["u"] = *e.u;
  return j;
}

json run_json(const DbbRunSummary& r) {
  json j = {{"source", r.source},
            {"radius_mm", r.radius_mm},
            {"height_mm", r.height_mm},
            {"direction", r.direction},
            {"feed_mm_per_min", r.feed_mm_per_min},
            {"n", r.n},
            {"circular_deviation_um", r.circular_deviation_um},
            {"residual_rms_um", r.residual_rms_um}};
  if (r.data_arc_deg) j["data_arc_deg"] = *r.data_arc_deg;
  if (r.gaps > 0) j["gaps"] = r.gaps;
  return j;
}

json contributions_json(const std::vector<DbbContribution>& list, bool with_plane) {
  json a = json::array();
  for (const DbbContribution& c : list) {
    json j = {{"name", c.name},
              {"contribution_um", c.contribution_um},
              {"percent_of_circular_deviation", finite_or_null(c.percent_of_circular_deviation)}};
    if (with_plane) j["plane"] = c.plane;
    a.push_back(std::move(j));
  }
  return a;
}

json fit_json(const DbbFit& f) {
  json j = {{"rms_um", f.rms_um}, {"n", f.n}, {"unidentifiable", f.unidentifiable}};
  if (std::isfinite(f.condition_number))
    j["condition_number"] = f.condition_number;
  else
    j["condition_number"] = "inf";
  if (!f.combinations.empty()) {
    json& c = j["combinations"] = json::array();
    for (const DbbCombination& k : f.combinations)
      c.push_back({{"expression", k.expression}, {"value", k.value}, {"u", k.u}});
  }
  if (!f.message.empty()) j["message"] = f.message;
  if (!f.why.empty()) j["why"] = f.why;
  return j;
}

json or_not_recorded(const std::optional<double>& v) { return v ? json(*v) : json(not_recorded); }

json conditions_json(const DbbTestConditions& c) {
  return {{"radius_mm", c.radius_mm},
          {"height_mm", c.height_mm},
          {"feed_mm_per_min", c.feed_mm_per_min},
          {"direction", c.direction},
          {"data_arc_deg", c.data_arc_deg},
          {"partial_arc", c.partial_arc},
          {"samples", c.samples},
          {"spacing_deg", c.spacing_deg},
          {"gaps", c.gaps},
          {"feed_in_deg", or_not_recorded(c.feed_in_deg)},
          {"feed_out_deg", or_not_recorded(c.feed_out_deg)},
          {"temperature_c", or_not_recorded(c.temperature_c)}};
}

json standards_json(const DbbStandards& s) {
  json j = {{"runs", json::array()}, {"pairs", json::array()}};
  for (const DbbStandardRun& r : s.runs) {
    json e = {{"run", r.run}, {"source", r.source}, {"over", r.over}, {"conditions", conditions_json(r.conditions)}};
    for (const RunFigure& f : run_figures) e[name(*f.entry)] = {{"value", r.*f.value}};
    j["runs"].push_back(std::move(e));
  }
  for (const DbbStandardPair& p : s.pairs) {
    json e = {{"ccw_run", p.ccw_run}, {"cw_run", p.cw_run}, {"common_arc_deg", p.common_arc_deg}, {"over", p.over}};
    for (const PairFigure& f : pair_figures) e[name(*f.entry)] = {{"value", p.*f.value}};
    j["pairs"].push_back(std::move(e));
  }
  return j;
}

json axis_figures_json(const std::map<std::string, DbbAxisFigure>& figures) {
  json j = json::object();
  for (const auto& [figure_name, f] : figures) {
    json e = estimate_json(f.estimate);
    e["axis"] = f.axis;
    e["consistent"] = f.consistent;
    e["from"] = json::array();
    for (const auto& [plane, value] : f.from) {
      json q = estimate_json(value);
      q["plane"] = plane;
      e["from"].push_back(std::move(q));
    }
    if (!f.note.empty()) e["note"] = f.note;
    j[figure_name] = std::move(e);
  }
  return j;
}

json estimates_json(const std::map<std::string, DbbEstimate>& estimates) {
  json j = json::object();
  for (const auto& [figure_name, e] : estimates) j[figure_name] = estimate_json(e);
  return j;
}

// ---- reading: every key optional, every present one of its type (json_fields.hpp) --------------------------

// A number, or "not recorded" (nullopt).
void read_recorded(const json& o, const std::string& where, const char* key, std::optional<double>& out) {
  const json* v = field(o, where, key, "a number or \"not recorded\"",
                        [](const json& e) { return e.is_number() || (e.is_string() && e == not_recorded); });
  if (v != nullptr) out = v->is_number() ? std::optional<double>(v->get<double>()) : std::nullopt;
}

DbbEstimate estimate_from(const json& o, const std::string& w) {
  DbbEstimate e;
  read(o, w, "value", e.value);
  read(o, w, "u", e.u);
  return e;
}

DbbRunSummary run_from(const json& o, const std::string& w) {
  DbbRunSummary r;
  read(o, w, "source", r.source);
  read(o, w, "radius_mm", r.radius_mm);
  read(o, w, "height_mm", r.height_mm);
  read(o, w, "direction", r.direction);
  read(o, w, "feed_mm_per_min", r.feed_mm_per_min);
  read(o, w, "n", r.n);
  read(o, w, "circular_deviation_um", r.circular_deviation_um);
  read(o, w, "residual_rms_um", r.residual_rms_um);
  read(o, w, "data_arc_deg", r.data_arc_deg);
  read(o, w, "gaps", r.gaps);
  return r;
}

DbbContribution contribution_from(const json& o, const std::string& w) {
  DbbContribution c;
  read(o, w, "plane", c.plane);
  read(o, w, "name", c.name);
  read(o, w, "contribution_um", c.contribution_um);
  read(o, w, "percent_of_circular_deviation", c.percent_of_circular_deviation);
  return c;
}

DbbCombination combination_from(const json& o, const std::string& w) {
  DbbCombination c;
  read(o, w, "expression", c.expression);
  read(o, w, "value", c.value);
  read(o, w, "u", c.u);
  return c;
}

DbbFit fit_from(const json& o, const char* key) {
  DbbFit f;
  const json* v = object_field(o, "", key);
  if (v == nullptr) return f;
  const std::string w = key;
  read(*v, w, "rms_um", f.rms_um);
  read(*v, w, "n", f.n);
  if (const json* c = field(*v, w, "condition_number", "a number or \"inf\"",
                            [](const json& e) { return e.is_number() || (e.is_string() && e == "inf"); }))
    f.condition_number = c->is_number() ? c->get<double>() : std::numeric_limits<double>::infinity();
  read(*v, w, "unidentifiable", f.unidentifiable);
  read_objects(*v, w, "combinations", f.combinations, combination_from);
  read(*v, w, "message", f.message);
  read(*v, w, "why", f.why);
  return f;
}

DbbTestConditions conditions_from(const json& o, const std::string& where) {
  DbbTestConditions c;
  const json* v = object_field(o, where, "conditions");
  if (v == nullptr) return c;
  const std::string w = at(where, "conditions");
  read(*v, w, "radius_mm", c.radius_mm);
  read(*v, w, "height_mm", c.height_mm);
  read(*v, w, "feed_mm_per_min", c.feed_mm_per_min);
  read(*v, w, "direction", c.direction);
  read(*v, w, "data_arc_deg", c.data_arc_deg);
  read(*v, w, "partial_arc", c.partial_arc);
  read(*v, w, "samples", c.samples);
  read(*v, w, "spacing_deg", c.spacing_deg);
  read(*v, w, "gaps", c.gaps);
  read_recorded(*v, w, "feed_in_deg", c.feed_in_deg);
  read_recorded(*v, w, "feed_out_deg", c.feed_out_deg);
  read_recorded(*v, w, "temperature_c", c.temperature_c);
  return c;
}

// A standards' figure {"value": v} under its catalogue name.
void read_figure(const json& o, const std::string& w, const Parameter& entry, double& out) {
  const std::string key = name(entry);
  if (const json* f = object_field(o, w, key.c_str())) read(*f, at(w, key.c_str()), "value", out);
}

DbbStandardRun standard_run_from(const json& o, const std::string& w) {
  DbbStandardRun r;
  read(o, w, "run", r.run);
  read(o, w, "source", r.source);
  read(o, w, "over", r.over);
  r.conditions = conditions_from(o, w);
  for (const RunFigure& f : run_figures) read_figure(o, w, *f.entry, r.*f.value);
  return r;
}

DbbStandardPair standard_pair_from(const json& o, const std::string& w) {
  DbbStandardPair p;
  read(o, w, "ccw_run", p.ccw_run);
  read(o, w, "cw_run", p.cw_run);
  read(o, w, "common_arc_deg", p.common_arc_deg);
  read(o, w, "over", p.over);
  for (const PairFigure& f : pair_figures) read_figure(o, w, *f.entry, p.*f.value);
  return p;
}

DbbAxisFigure axis_figure_from(const json& o, const std::string& w) {
  DbbAxisFigure f;
  f.estimate = estimate_from(o, w);
  read(o, w, "axis", f.axis);
  read(o, w, "consistent", f.consistent);
  read_objects(o, w, "from", f.from, [](const json& e, const std::string& place) {
    std::string plane;
    read(e, place, "plane", plane);
    return std::pair{plane, estimate_from(e, place)};
  });
  read(o, w, "note", f.note);
  return f;
}

DbbPlanesSummary summary_from(const json& o, const std::string& w) {
  DbbPlanesSummary s;
  read(o, w, "planes", s.planes);
  read_named(o, w, "squareness", s.squareness, estimate_from);
  read_named(o, w, "scale_mismatch", s.scale_mismatch, estimate_from);
  read_named(o, w, "backlash", s.backlash, axis_figure_from);
  read_named(o, w, "scale", s.scale, axis_figure_from);
  read_objects(o, w, "ranking", s.ranking, contribution_from);
  read(o, w, "circular_deviation_um", s.circular_deviation_um);
  read(o, w, "notes", s.notes);
  return s;
}

DbbRecord read_record(const json& j) {
  if (!j.is_object()) fail("", std::string("a DBB record is an object, not ") + j.type_name());
  DbbRecord r;
  const std::string w;  // the top level
  read_objects(j, w, "runs", r.runs, run_from);
  read_objects(j, w, "ranking", r.ranking, contribution_from);
  read(j, w, "ranking_model", r.ranking_model);
  read(j, w, "notes", r.notes);
  r.fit = fit_from(j, "fit");
  r.diagnostics_fit = fit_from(j, "diagnostics_fit");
  if (const json* s = object_field(j, w, "standards")) {
    read_objects(*s, "standards", "runs", r.standards.runs, standard_run_from);
    read_objects(*s, "standards", "pairs", r.standards.pairs, standard_pair_from);
  }
  if (const json* s = object_field(j, w, "summary")) r.summary = summary_from(*s, "summary");
  return r;
}

}  // namespace

bool is_dbb_record_key(std::string_view key) {
  for (const std::string_view k : record_keys)
    if (k == key) return true;
  return false;
}

json to_json(const DbbPlanesSummary& s) {
  json j;
  j["planes"] = s.planes;
  j["squareness"] = estimates_json(s.squareness);
  j["scale_mismatch"] = estimates_json(s.scale_mismatch);
  j["backlash"] = axis_figures_json(s.backlash);
  j["scale"] = axis_figures_json(s.scale);
  j["ranking"] = contributions_json(s.ranking, true);
  j["circular_deviation_um"] = s.circular_deviation_um;
  j["notes"] = s.notes;
  return j;
}

json to_json(const DbbRecord& r) {
  json j = json::object();
  j["runs"] = json::array();
  for (const DbbRunSummary& run : r.runs) j["runs"].push_back(run_json(run));
  j["ranking"] = contributions_json(r.ranking, false);
  j["ranking_model"] = r.ranking_model;
  j["notes"] = r.notes;
  j["fit"] = fit_json(r.fit);
  j["diagnostics_fit"] = fit_json(r.diagnostics_fit);
  j["standards"] = standards_json(r.standards);
  if (r.summary) j["summary"] = to_json(*r.summary);
  return j;
}

DbbRecord dbb_record_from_json(const json& j) {
  return rethrown_as<ParamsFormatError>([&] { return read_record(j); });
}

}  // namespace guideway::results
