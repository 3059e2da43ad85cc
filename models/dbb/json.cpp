// A DBB identification as JSON (json.hpp): the shape of `guideway identify dbb --json` and of the daemon's PARAMS.
#include "models/dbb/json.hpp"

#include <cmath>
#include <optional>
#include <string_view>

#include "results/parameters.hpp"

namespace guideway::models::dbb {

namespace {

nlohmann::json value_json(const Estimate& e) {
  nlohmann::json j = {{"value", e.value}};
  if (e.fitted && std::isfinite(e.u)) j["u"] = e.u;
  return j;
}

// The estimates as PARAMS' figures: u left out where the fit did not determine one.
results::FigureGroup figures(std::string_view group, const std::vector<Estimate>& list) {
  results::FigureGroup g{std::string(group), {}};
  for (const auto& e : list)
    g.figures.push_back(results::figure(
        e.name, e.value, e.fitted && std::isfinite(e.u) ? std::optional<double>(e.u) : std::nullopt, group));
  return g;
}

nlohmann::json fit_json(const FitSummary& f) {
  nlohmann::json j = {{"rms_um", f.rms_um}, {"n", f.n}, {"unidentifiable", f.unidentifiable}};
  if (std::isfinite(f.condition_number))
    j["condition_number"] = f.condition_number;
  else
    j["condition_number"] = "inf";
  if (!f.combinations.empty()) {
    auto& c = j["combinations"] = nlohmann::json::array();
    for (const auto& k : f.combinations) c.push_back({{"expression", k.expression}, {"value", k.value}, {"u", k.u}});
  }
  if (!f.message.empty()) j["message"] = f.message;
  if (!f.why.empty()) j["why"] = f.why;
  return j;
}

nlohmann::json u_json(double value, double u) {
  nlohmann::json j = {{"value", value}};
  if (std::isfinite(u)) j["u"] = u;
  return j;
}

nlohmann::json axis_figures_json(const std::vector<AxisFigure>& list) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& f : list) {
    nlohmann::json e = u_json(f.value, f.u);
    e["axis"] = f.axis;
    e["consistent"] = f.consistent;
    e["from"] = nlohmann::json::array();
    for (const auto& p : f.from) {
      nlohmann::json q = u_json(p.value, p.u);
      q["plane"] = p.plane;
      e["from"].push_back(q);
    }
    if (!f.note.empty()) e["note"] = f.note;
    j[f.name] = e;
  }
  return j;
}

nlohmann::json or_not_recorded(const std::optional<double>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json("not recorded");
}

nlohmann::json conditions_json(const TestConditions& c) {
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

// The figures under their catalogue names (results/parameters.hpp), each {"value": v}; "over" says what
// they are over: "the full circle" or "the 220 deg arc" (a partial arc's figures are over its arc only).
nlohmann::json standards_json(const StandardFigures& s) {
  namespace r = results;
  const auto over = [](double arc_deg, bool partial) {
    return partial ? "the " + std::to_string(std::lround(arc_deg)) + " deg arc" : std::string("the full circle");
  };
  nlohmann::json j = {{"runs", nlohmann::json::array()}, {"pairs", nlohmann::json::array()}};
  for (std::size_t k = 0; k < s.runs.size(); ++k) {
    const RunFigures& f = s.runs[k];
    j["runs"].push_back({{"run", k + 1},
                         {"source", f.source},
                         {"over", over(f.conditions.data_arc_deg, f.conditions.partial_arc)},
                         {"conditions", conditions_json(f.conditions)},
                         {r::name(r::iso_circular_deviation), {{"value", f.iso_circular_deviation_um}}},
                         {r::name(r::iso_radial_deviation_max), {{"value", f.iso_radial_deviation_max_um}}},
                         {r::name(r::iso_radial_deviation_min), {{"value", f.iso_radial_deviation_min_um}}},
                         {r::name(r::asme_circularity), {{"value", f.asme_circularity_um}}}});
  }
  for (const PairFigures& p : s.pairs) {
    const bool partial = s.runs[p.ccw].conditions.partial_arc || s.runs[p.cw].conditions.partial_arc;
    j["pairs"].push_back(
        {{"ccw_run", p.ccw + 1},
         {"cw_run", p.cw + 1},
         {"common_arc_deg", p.common_arc_deg},
         {"over", over(p.common_arc_deg, partial)},
         {r::name(r::iso_circular_hysteresis), {{"value", p.iso_circular_hysteresis_um}}},
         {r::name(r::iso_bidirectional_deviation), {{"value", p.iso_bidirectional_deviation_um}}},
         {r::name(r::asme_hysteresis), {{"value", p.asme_hysteresis_um}}},
         {r::name(r::asme_bidirectional_circularity), {{"value", p.asme_bidirectional_circularity_um}}}});
  }
  return j;
}

}  // namespace

nlohmann::json to_json(const PlanesSummary& s) {
  nlohmann::json j;
  j["planes"] = s.planes;
  j["squareness"] = nlohmann::json::object();
  for (const auto& e : s.squareness) j["squareness"][e.name] = value_json(e);
  j["scale_mismatch"] = nlohmann::json::object();
  for (const auto& e : s.scale_mismatch) j["scale_mismatch"][e.name] = value_json(e);
  j["backlash"] = axis_figures_json(s.backlash);
  j["scale"] = axis_figures_json(s.scale);
  j["ranking"] = nlohmann::json::array();
  for (const auto& c : s.ranking)
    j["ranking"].push_back(
        {{"plane", c.plane},
         {"name", c.name},
         {"contribution_um", c.contribution_um},
         {"percent_of_circular_deviation", std::isfinite(c.percent) ? nlohmann::json(c.percent) : nlohmann::json()}});
  j["circular_deviation_um"] = s.circular_deviation_um;
  j["notes"] = s.notes;
  return j;
}

results::Params to_params(const Identification& id) {
  results::Params p;
  p.model = id.model;
  p.plane = id.plane;
  p.groups.push_back(figures(results::backlash.group, id.diagnostics));
  p.groups.push_back(figures(results::lai_S_x.group, id.lai3));
  if (!id.beside.empty())  // only when terms were fitted beside (compensation's identification)
    p.groups.push_back(figures("beside", id.beside));
  nlohmann::json& j = p.record;
  j["runs"] = nlohmann::json::array();
  for (const auto& r : id.runs) {
    j["runs"].push_back({{"source", r.source},
                         {"radius_mm", r.radius_mm},
                         {"height_mm", r.height_mm},
                         {"direction", r.direction},
                         {"feed_mm_per_min", r.feed_mm_per_min},
                         {"n", r.n},
                         {"circular_deviation_um", r.circular_deviation_um},
                         {"residual_rms_um", r.residual_rms_um}});
    if (r.data_arc_deg < 359.0) j["runs"].back()["data_arc_deg"] = r.data_arc_deg;  // a partial arc
    if (r.gaps > 0) j["runs"].back()["gaps"] = r.gaps;
  }
  j["ranking"] = nlohmann::json::array();
  for (const auto& c : id.ranking)
    j["ranking"].push_back(
        {{"name", c.name},
         {"contribution_um", c.contribution_um},
         {"percent_of_circular_deviation", std::isfinite(c.percent) ? nlohmann::json(c.percent) : nlohmann::json()}});
  j["ranking_model"] = id.ranking_model;
  j["notes"] = id.notes;
  j["fit"] = fit_json(id.fit);
  j["diagnostics_fit"] = fit_json(id.diagnostics_fit);
  j["standards"] = standards_json(id.standards);
  return p;
}

nlohmann::json to_json(const Identification& id) { return results::to_json(to_params(id)); }

}  // namespace guideway::models::dbb
