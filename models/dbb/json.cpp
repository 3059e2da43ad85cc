// A DBB identification as JSON (json.hpp): the shape of `guideway identify dbb --json` and of the daemon's PARAMS.
#include "models/dbb/json.hpp"

#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "results/parameters.hpp"

namespace guideway::models::dbb {

namespace {

// A value with its u where there is one (finite, and for an estimate fitted): unknown or non-fitted
// uncertainties are left out, never null.
results::DbbEstimate estimate(double value, double u, bool fitted = true) {
  return {value, fitted && std::isfinite(u) ? std::optional<double>(u) : std::nullopt};
}

// The estimates as PARAMS' figures.
results::FigureGroup figures(std::string_view group, const std::vector<Estimate>& list) {
  results::FigureGroup g{std::string(group), {}};
  for (const auto& e : list)
    g.figures.push_back(results::figure(e.name, e.value, estimate(e.value, e.u, e.fitted).u, group));
  return g;
}

results::DbbFit fit_record(const FitSummary& f) {
  results::DbbFit out{f.rms_um, f.n, f.condition_number, f.unidentifiable, {}, f.message, f.why};
  for (const auto& k : f.combinations) out.combinations.push_back({k.expression, k.value, k.u});
  return out;
}

std::map<std::string, results::DbbAxisFigure> axis_figures(const std::vector<AxisFigure>& list) {
  std::map<std::string, results::DbbAxisFigure> out;
  for (const auto& f : list) {
    results::DbbAxisFigure& a = out[f.name];
    a = {f.axis, estimate(f.value, f.u), f.consistent, {}, f.note};
    for (const auto& p : f.from) a.from.emplace_back(p.plane, estimate(p.value, p.u));
  }
  return out;
}

results::DbbTestConditions conditions_record(const TestConditions& c) {
  return {c.radius_mm,   c.height_mm, c.feed_mm_per_min, c.direction,   c.data_arc_deg, c.partial_arc,
          c.samples,     c.spacing_deg, c.gaps,          c.feed_in_deg, c.feed_out_deg, c.temperature_c};
}

// "over" says what the figures are over: "the full circle" or "the 220 deg arc" (a partial arc's figures are
// over its arc only).
results::DbbStandards standards_record(const StandardFigures& s) {
  const auto over = [](double arc_deg, bool partial) {
    return partial ? "the " + std::to_string(std::lround(arc_deg)) + " deg arc" : std::string("the full circle");
  };
  results::DbbStandards out;
  for (std::size_t k = 0; k < s.runs.size(); ++k) {
    const RunFigures& f = s.runs[k];
    out.runs.push_back({k + 1, f.source, over(f.conditions.data_arc_deg, f.conditions.partial_arc),
                        conditions_record(f.conditions), f.iso_circular_deviation_um, f.iso_radial_deviation_max_um,
                        f.iso_radial_deviation_min_um, f.asme_circularity_um});
  }
  for (const PairFigures& p : s.pairs) {
    const bool partial = s.runs[p.ccw].conditions.partial_arc || s.runs[p.cw].conditions.partial_arc;
    out.pairs.push_back({p.ccw + 1, p.cw + 1, p.common_arc_deg, over(p.common_arc_deg, partial),
                         p.iso_circular_hysteresis_um, p.iso_bidirectional_deviation_um, p.asme_hysteresis_um,
                         p.asme_bidirectional_circularity_um});
  }
  return out;
}

// NaN where the part of G is not a number (no G): null in the JSON.
double finite_or_nan(double v) { return std::isfinite(v) ? v : results::record_nan; }

}  // namespace

results::DbbPlanesSummary planes_record(const PlanesSummary& s) {
  results::DbbPlanesSummary out;
  out.planes = s.planes;
  for (const auto& e : s.squareness) out.squareness[e.name] = estimate(e.value, e.u, e.fitted);
  for (const auto& e : s.scale_mismatch) out.scale_mismatch[e.name] = estimate(e.value, e.u, e.fitted);
  out.backlash = axis_figures(s.backlash);
  out.scale = axis_figures(s.scale);
  for (const auto& c : s.ranking)
    out.ranking.push_back({c.plane, c.name, c.contribution_um, finite_or_nan(c.percent)});
  out.circular_deviation_um = s.circular_deviation_um;
  out.notes = s.notes;
  return out;
}

nlohmann::json to_json(const PlanesSummary& s) { return results::to_json(planes_record(s)); }

results::Params to_params(const Identification& id) {
  results::Params p;
  p.model = id.model;
  p.plane = id.plane;
  p.groups.push_back(figures(results::backlash.group, id.diagnostics));
  p.groups.push_back(figures(results::lai_S_x.group, id.lai3));
  if (!id.beside.empty())  // only when terms were fitted beside (compensation's identification)
    p.groups.push_back(figures("beside", id.beside));
  results::DbbRecord& r = p.dbb.emplace();
  for (const auto& run : id.runs)
    r.runs.push_back({run.source, run.radius_mm, run.height_mm, run.direction, run.feed_mm_per_min, run.n,
                      run.circular_deviation_um, run.residual_rms_um,
                      run.data_arc_deg < 359.0 ? std::optional<double>(run.data_arc_deg) : std::nullopt,  // partial
                      run.gaps});
  for (const auto& c : id.ranking) r.ranking.push_back({{}, c.name, c.contribution_um, finite_or_nan(c.percent)});
  r.ranking_model = id.ranking_model;
  r.notes = id.notes;
  r.fit = fit_record(id.fit);
  r.diagnostics_fit = fit_record(id.diagnostics_fit);
  r.standards = standards_record(id.standards);
  return p;
}

nlohmann::json to_json(const Identification& id) { return results::to_json(to_params(id)); }

}  // namespace guideway::models::dbb
