// An explanation's JSON (explanation.hpp), written and read: the one place EXPLAIN's keys are spelled.
#include "results/explanation.hpp"

#include <nlohmann/json.hpp>

#include "results/json_fields.hpp"

namespace guideway::results {

namespace {

using nlohmann::json;

// ---- writing ---------------------------------------------------------------------------------------------

using json_fields::finite_or_null;

json pair_json(const std::pair<double, double>& p) {
  return json::array({finite_or_null(p.first), finite_or_null(p.second)});
}

json numbers_json(const std::vector<double>& v) {
  json a = json::array();
  for (const double e : v) a.push_back(finite_or_null(e));
  return a;
}

json fit_json(const ExplainFit& f) {
  return {{"rms_um", finite_or_null(f.rms_um)},
          {"bic", finite_or_null(f.bic)},
          {"heldout_rms_um", finite_or_null(f.heldout_rms_um)},
          {"parameters", f.parameters}};
}

json location_json(const ExplainLocation& l) {
  json j = {{"run", l.run},
            {"source", l.source},
            {"where", pair_json(l.where)},
            {"t_machine_s", pair_json(l.t_machine_s)},
            {"peak_um", finite_or_null(l.peak_um)},
            {"once", l.repeats_in.empty()},
            {"repeats_in", l.repeats_in},
            {"set_aside", l.set_aside}};
  // Without times, the readings' order from the run's first (0), never seconds.
  j[l.timed ? "t_from_run_start_s" : "readings_from_run_start"] = pair_json(l.from_run_start);
  return j;
}

json places_json(const std::vector<ExplainPlace>& places) {
  json a = json::array();
  for (const auto& m : places) {
    json ranges = json::array();
    for (const auto& r : m.ranges) ranges.push_back(pair_json(r));
    json place{
        {"domain", m.domain}, {"where", m.where}, {"band", m.band}, {"evidence", m.evidence}, {"ranges", ranges}};
    if (!m.locations.empty()) {
      json locations = json::array();
      for (const auto& l : m.locations) locations.push_back(location_json(l));
      place["locations"] = std::move(locations);
    }
    a.push_back(std::move(place));
  }
  return a;
}

json finding_json(const ExplainFinding& f) {
  json parameters = json::object();
  for (const auto& [name, e] : f.parameters)
    parameters[name] = {{"value", finite_or_null(e.value)}, {"u", finite_or_null(e.u)}};
  return {{"effect", f.effect},
          {"parameters", std::move(parameters)},
          {"delta_bic", finite_or_null(f.delta_bic)},
          {"p_value", finite_or_null(f.p_value)},
          {"rms_um_after", finite_or_null(f.rms_um_after)},
          {"heldout_rms_um_after", finite_or_null(f.heldout_rms_um_after)},
          {"structure_removed", finite_or_null(f.structure_removed)},
          {"contribution_um", finite_or_null(f.contribution_um)},
          {"percent_of_deviation", finite_or_null(f.percent_of_deviation)},
          {"why", f.why}};
}

json findings_json(const std::vector<ExplainFinding>& findings) {
  json a = json::array();
  for (const auto& f : findings) a.push_back(finding_json(f));
  return a;
}

json residuals_json(const ExplainResiduals& r) {
  json steps = json::array();
  for (const auto& st : r.steps) {
    json runs = json::array();
    for (const auto& curve : st.residual_um) runs.push_back(numbers_json(curve));
    steps.push_back({{"label", st.label}, {"residual_um", std::move(runs)}});
  }
  return {{"domain", r.domain}, {"x", numbers_json(r.x)}, {"runs", r.runs}, {"steps", std::move(steps)}};
}

// ---- reading: every key optional, every present one of its type (json_fields.hpp) --------------------------

using namespace json_fields;

ExplainFit fit_from(const json& o, const std::string& where, const char* key) {
  ExplainFit f;
  const json* v = field(o, where, key, "an object", [](const json& e) { return e.is_object(); });
  if (v == nullptr) return f;
  const std::string w = at(where, key);
  read(*v, w, "rms_um", f.rms_um);
  read(*v, w, "bic", f.bic);
  read(*v, w, "heldout_rms_um", f.heldout_rms_um);
  read(*v, w, "parameters", f.parameters);
  return f;
}

ExplainLocation location_from(const json& o, const std::string& w) {
  ExplainLocation l;
  read(o, w, "run", l.run);
  read(o, w, "source", l.source);
  read(o, w, "where", l.where);
  read(o, w, "t_machine_s", l.t_machine_s);
  read(o, w, "peak_um", l.peak_um);
  read(o, w, "repeats_in", l.repeats_in);
  read(o, w, "set_aside", l.set_aside);
  l.timed = !o.contains("readings_from_run_start");
  read(o, w, l.timed ? "t_from_run_start_s" : "readings_from_run_start", l.from_run_start);
  return l;
}

ExplainPlace place_from(const json& o, const std::string& w) {
  ExplainPlace m;
  read(o, w, "domain", m.domain);
  read(o, w, "where", m.where);
  read(o, w, "band", m.band);
  read(o, w, "evidence", m.evidence);
  if (const json* a = array_field(o, w, "ranges")) {
    for (std::size_t i = 0; i < a->size(); ++i) {
      const std::vector<double> r = numbers_at((*a)[i], at(at(w, "ranges"), i));
      if (r.size() != 2) fail("", at(at(w, "ranges"), i) + " must be two numbers (or nulls)");
      m.ranges.emplace_back(r[0], r[1]);
    }
  }
  read_objects(o, w, "locations", m.locations, location_from);
  return m;
}

ExplainFinding finding_from(const json& o, const std::string& w) {
  ExplainFinding f;
  const auto effect = o.find("effect");
  if (effect == o.end() || !effect->is_string()) fail("", w + " needs \"effect\" as a text");
  f.effect = effect->get<std::string>();
  read_named(o, w, "parameters", f.parameters, [](const json& v, const std::string& place) {
    ExplainEstimate e;
    read(v, place, "value", e.value);
    read(v, place, "u", e.u);
    return e;
  });
  read(o, w, "delta_bic", f.delta_bic);
  read(o, w, "p_value", f.p_value);
  read(o, w, "rms_um_after", f.rms_um_after);
  read(o, w, "heldout_rms_um_after", f.heldout_rms_um_after);
  read(o, w, "structure_removed", f.structure_removed);
  read(o, w, "contribution_um", f.contribution_um);
  read(o, w, "percent_of_deviation", f.percent_of_deviation);
  read(o, w, "why", f.why);
  return f;
}

ExplainConsidered considered_from(const json& o, const std::string& w) {
  ExplainConsidered c;
  read(o, w, "effect", c.effect);
  read(o, w, "delta_bic", c.delta_bic);
  read(o, w, "p_value", c.p_value);
  read(o, w, "verdict", c.verdict);
  return c;
}

ExplainResidualStep step_from(const json& o, const std::string& w) {
  ExplainResidualStep s;
  read(o, w, "label", s.label);
  if (const json* a = array_field(o, w, "residual_um"))
    for (std::size_t i = 0; i < a->size(); ++i)
      s.residual_um.push_back(numbers_at((*a)[i], at(at(w, "residual_um"), i)));
  return s;
}

ExplainResiduals residuals_from(const json& o, const std::string& w) {
  ExplainResiduals r;
  read(o, w, "domain", r.domain);
  read(o, w, "x", r.x);
  read(o, w, "runs", r.runs);
  read_objects(o, w, "steps", r.steps, step_from);
  return r;
}

}  // namespace

Explanation not_analysed(std::string model, const std::string& reason) {
  Explanation e;
  e.model = std::move(model);
  e.not_analysed = reason;
  e.unexplained = true;
  e.notes = {"not analysed: " + reason};
  return e;
}

json to_json(const Explanation& e) {
  if (!e.not_analysed.empty())
    return {{"model", e.model},
            {"not_analysed", e.not_analysed},
            {"findings", findings_json(e.findings)},
            {"unexplained", e.unexplained},
            {"notes", e.notes}};
  json j;
  j["model"] = e.model;
  j["n"] = e.n;
  if (e.set_aside_samples > 0) j["set_aside_samples"] = e.set_aside_samples;
  j["noise_um"] = finite_or_null(e.noise_um);
  j["heldout_scheme"] = e.heldout_scheme;
  j["baseline"] = fit_json(e.baseline);
  j["mismatch"] = places_json(e.mismatch);
  j["findings"] = findings_json(e.findings);
  j["final"] = fit_json(e.final_fit);
  j["unexplained"] = e.unexplained;
  if (e.deviation) j["deviation"] = {{"name", e.deviation->name}, {"value_um", finite_or_null(e.deviation->value_um)}};
  j["remaining"] = places_json(e.remaining);
  json considered = json::array();
  for (const auto& k : e.considered)
    considered.push_back({{"effect", k.effect},
                          {"delta_bic", finite_or_null(k.delta_bic)},
                          {"p_value", finite_or_null(k.p_value)},
                          {"verdict", k.verdict}});
  j["considered"] = std::move(considered);
  j["notes"] = e.notes;
  if (e.residuals) j["residuals"] = residuals_json(*e.residuals);
  return j;
}

namespace {

Explanation read_explanation(const json& j) {
  if (!j.is_object()) fail("", std::string("an explanation is a JSON object, not ") + j.type_name());
  Explanation e;
  const std::string w;  // the top level
  read(j, w, "model", e.model);
  read(j, w, "not_analysed", e.not_analysed);
  read(j, w, "n", e.n);
  read(j, w, "set_aside_samples", e.set_aside_samples);
  read(j, w, "noise_um", e.noise_um);
  read(j, w, "heldout_scheme", e.heldout_scheme);
  e.baseline = fit_from(j, w, "baseline");
  read_objects(j, w, "mismatch", e.mismatch, place_from);
  read_objects(j, w, "findings", e.findings, finding_from);
  e.final_fit = fit_from(j, w, "final");
  read(j, w, "unexplained", e.unexplained);
  if (const json* d = field(j, w, "deviation", "an object", [](const json& v) { return v.is_object(); })) {
    e.deviation.emplace();
    read(*d, "deviation", "name", e.deviation->name);
    read(*d, "deviation", "value_um", e.deviation->value_um);
  }
  read_objects(j, w, "remaining", e.remaining, place_from);
  read_objects(j, w, "considered", e.considered, considered_from);
  read(j, w, "notes", e.notes);
  if (const json* r = field(j, w, "residuals", "an object", [](const json& v) { return v.is_object(); }))
    e.residuals = residuals_from(*r, "residuals");
  return e;
}

}  // namespace

Explanation explanation_from_json(const json& j) {
  return json_fields::rethrown_as<ExplanationFormatError>([&] { return read_explanation(j); });
}

bool is_explanation(const json& j) {
  if (!j.is_object()) return false;
  const auto findings = j.find("findings");
  if (findings == j.end() || !findings->is_array()) return false;
  const auto reason = j.find("not_analysed");
  return j.contains("baseline") || (reason != j.end() && reason->is_string());
}

json found_json(const Explanation& e) {
  json j = {{"findings", json::array()}, {"unexplained", e.unexplained}};
  for (const auto& f : e.findings)
    j["findings"].push_back({{"effect", f.effect}, {"contribution_um", finite_or_null(f.contribution_um)}});
  if (!e.not_analysed.empty()) j["not_analysed"] = e.not_analysed;
  return j;
}

}  // namespace guideway::results
