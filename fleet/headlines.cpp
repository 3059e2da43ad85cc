#include "fleet/headlines.hpp"

#include <cmath>

#include "core/number_format.hpp"

namespace guideway::fleet {

namespace {

// Where a figure is in the JSON: alternatives, the first found wins. An alternative is a value and an
// optional uncertainty pointer; "{a}"/"{b}" stand for the DBB plane's axis letters.
struct Source {
  std::string value;
  std::string u;
};
struct FigureSpec {
  const char* name;
  const char* label;
  const char* unit;
  std::vector<Source> sources;
};

// An estimate object {"value": v, "u": u} (models/dbb/json.cpp, the sessions' figure groups).
Source estimate(const std::string& pointer) { return {pointer + "/value", pointer + "/u"}; }

const std::vector<FigureSpec>& spec_of(std::string_view kind) {
  static const std::vector<FigureSpec> dbb = {
      {"circular_deviation_um", "G", "µm", {estimate("/diagnostics/circular_deviation_um")}},
      {"squareness_urad", "squareness", "µrad", {estimate("/diagnostics/squareness_urad")}},
      {"backlash_{a}_um",
       "backlash {a}",
       "µm",
       {estimate("/diagnostics/backlash_{a}_um"), estimate("/lai3/backlash_{a}_um")}},
      {"backlash_{b}_um",
       "backlash {b}",
       "µm",
       {estimate("/diagnostics/backlash_{b}_um"), estimate("/lai3/backlash_{b}_um")}},
      {"scale_{a}_ppm", "scale {a}", "ppm", {estimate("/diagnostics/scale_{a}_ppm")}},
      {"scale_{b}_ppm", "scale {b}", "ppm", {estimate("/diagnostics/scale_{b}_ppm")}},
  };
  static const std::vector<FigureSpec> runout = {
      {"squareness_urad", "squareness (run-out)", "µrad", {estimate("/squareness/squareness_urad")}},
      {"runout_um", "run-out", "µm", {estimate("/squareness/runout_um")}},
  };
  static const std::vector<FigureSpec> straightness = {
      {"horizontal_straightness_um",
       "straightness h",
       "µm",
       {{"/result/horizontal/least_squares/straightness_um", "/result/horizontal/least_squares/u_straightness_um"}}},
      {"vertical_straightness_um",
       "straightness v",
       "µm",
       {{"/result/vertical/least_squares/straightness_um", "/result/vertical/least_squares/u_straightness_um"}}},
  };
  static const std::vector<FigureSpec> profile = {
      {"straightness_lsq_um", "profile straightness", "µm", {estimate("/profile/straightness_lsq_um")}},
      {"form_straightness_um", "form straightness", "µm", {estimate("/profile/form_straightness_um")}},
  };
  static const std::vector<FigureSpec> none;
  if (kind == "dbb") return dbb;
  if (kind == "runout") return runout;
  if (kind == "straightness") return straightness;
  if (kind == "profile") return profile;
  return none;
}

std::string with_axes(std::string text, const std::string& a, const std::string& b) {
  for (const auto& [key, letter] : {std::pair<std::string, std::string>{"{a}", a}, {"{b}", b}}) {
    for (auto at = text.find(key); at != std::string::npos; at = text.find(key, at))
      text.replace(at, key.size(), letter);
  }
  return text;
}

std::optional<double> number_at(const nlohmann::json& j, const std::string& pointer) {
  if (pointer.empty()) return std::nullopt;
  const nlohmann::json::json_pointer p(pointer);
  if (!j.contains(p)) return std::nullopt;
  const auto& v = j.at(p);
  if (!v.is_number()) return std::nullopt;
  const double d = v.get<double>();
  return std::isfinite(d) ? std::optional<double>(d) : std::nullopt;
}

// The DBB figures are named after the plane's axes ("xy": x and y; "zx": z and x); x and y when the
// object names no plane (or one that is not two axis letters: such a result is refused at ingest).
std::pair<std::string, std::string> plane_axes(const nlohmann::json& params) {
  if (const auto it = params.find("plane"); it != params.end() && it->is_string()) {
    const auto& plane = it->get_ref<const std::string&>();
    const auto axis = [](char c) { return c == 'x' || c == 'y' || c == 'z'; };
    if (plane.size() == 2 && axis(plane[0]) && axis(plane[1]) && plane[0] != plane[1])
      return {plane.substr(0, 1), plane.substr(1, 1)};
  }
  return {"x", "y"};
}

}  // namespace

std::vector<Headline> headlines(std::string_view kind, const nlohmann::json& params) {
  const auto [a, b] = plane_axes(params);
  std::vector<Headline> out;
  for (const auto& f : spec_of(kind)) {
    for (const auto& src : f.sources) {
      const auto v = number_at(params, with_axes(src.value, a, b));
      if (!v) continue;
      out.push_back(
          {with_axes(f.name, a, b), with_axes(f.label, a, b), f.unit, *v, number_at(params, with_axes(src.u, a, b))});
      break;
    }
  }
  return out;
}

std::string figure_problem(std::string_view kind, const nlohmann::json& params) {
  const auto [a, b] = plane_axes(params);
  for (const auto& f : spec_of(kind)) {
    for (const auto& src : f.sources) {
      for (const auto& pointer : {with_axes(src.value, a, b), with_axes(src.u, a, b)}) {
        if (pointer.empty()) continue;
        const nlohmann::json::json_pointer p(pointer);
        if (!params.contains(p)) continue;
        const auto& v = params.at(p);
        if (!v.is_number() || !std::isfinite(v.get<double>()))
          return "the figure at " + pointer + " is " + (v.is_number() ? "not finite" : std::string(v.type_name())) +
                 ", expected a finite number";
      }
    }
  }
  return {};
}

ExplainSummary explain_summary(const nlohmann::json& explain) {
  ExplainSummary s;
  if (const auto it = explain.find("findings"); it != explain.end() && it->is_array()) {
    for (const auto& f : *it) {
      if (!f.is_object()) continue;
      Finding finding;
      // Typed reads that never throw: a row stored before ingest checked types must not stop a reader.
      const auto effect = f.find("effect");
      finding.effect = effect != f.end() && effect->is_string() ? effect->get<std::string>() : "?";
      const auto c = f.find("contribution_um");
      finding.contribution_um = c != f.end() && c->is_number() ? c->get<double>() : std::nan("");
      s.findings.push_back(std::move(finding));
    }
  }
  const auto u = explain.find("unexplained");
  s.unexplained = u != explain.end() && u->is_boolean() && u->get<bool>();
  const auto n = explain.find("not_analysed");
  if (n != explain.end() && n->is_string()) s.not_analysed = n->get<std::string>();
  return s;
}

std::string to_text(const ExplainSummary& s) {
  if (!s.not_analysed.empty()) return "not analysed";
  std::string out;
  for (const auto& f : s.findings) {
    if (!out.empty()) out += ", ";
    out += f.effect;
    if (std::isfinite(f.contribution_um)) out += " " + significant_digits(f.contribution_um, 3) + " µm";
  }
  if (out.empty()) out = "nothing found";
  if (s.unexplained) out += out == "nothing found" ? "; unexplained" : "; rest unexplained";
  return out;
}

bool moved(const Headline& latest, const Headline& previous) {
  if (!latest.u || !previous.u) return false;
  const double u = std::sqrt(*latest.u * *latest.u + *previous.u * *previous.u);
  return std::abs(latest.value - previous.value) > moved_coverage_factor * u;
}

}  // namespace guideway::fleet
