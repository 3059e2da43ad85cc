#include "fleet/headlines.hpp"

#include <cmath>

#include "core/number_format.hpp"
#include "results/parameters.hpp"
#include "results/session_kinds.hpp"

namespace guideway::fleet {

namespace {

std::optional<double> number_at(const nlohmann::json& j, const std::string& pointer) {
  if (pointer.empty()) return std::nullopt;
  const nlohmann::json::json_pointer p(pointer);
  if (!j.contains(p)) return std::nullopt;
  const auto& v = j.at(p);
  if (!v.is_number()) return std::nullopt;
  const double d = v.get<double>();
  return std::isfinite(d) ? std::optional<double>(d) : std::nullopt;
}

// A figure's value (and u) where the catalogue says it is: its own pointers, else an estimate object
// {"value": v, "u": u} in its group (models/dbb/json.cpp, the sessions' figure groups), else in the group
// it is also reported in.
std::optional<Headline> figure(const results::Parameter& p, const std::string& plane, int axis,
                               const nlohmann::json& params) {
  const std::string name = results::name(p, plane, axis);
  const auto headline = [&](const std::string& value_at, const std::string& u_at) -> std::optional<Headline> {
    const auto v = number_at(params, value_at);
    if (!v) return std::nullopt;
    return Headline{name, results::label(p, plane, axis), results::unit(p), *v, number_at(params, u_at)};
  };
  if (!p.value_at.empty()) return headline(std::string(p.value_at), std::string(p.u_at));
  for (const std::string_view group : {p.group, p.also_in}) {
    if (group.empty()) continue;
    const std::string at = "/" + std::string(group) + "/" + name;
    if (auto h = headline(at + "/value", at + "/u")) return h;
  }
  return std::nullopt;
}

}  // namespace

std::vector<Headline> headlines(std::string_view kind, const nlohmann::json& params) {
  // The DBB figures are named after the plane's axes ("xy": x and y; "zx": z and x).
  std::string plane = "xy";
  if (const auto it = params.find("plane"); it != params.end() && it->is_string() && it->get<std::string>().size() == 2)
    plane = it->get<std::string>();
  std::vector<Headline> out;
  for (const results::Parameter* p : results::headline_parameters(kind)) {
    const std::vector<int> axes = results::per_axis(*p) ? std::vector<int>{0, 1} : std::vector<int>{-1};
    for (const int axis : axes)
      if (auto h = figure(*p, plane, axis, params)) out.push_back(std::move(*h));
  }
  return out;
}
ExplainSummary explain_summary(const nlohmann::json& explain) {
  ExplainSummary s;
  if (const auto it = explain.find("findings"); it != explain.end() && it->is_array()) {
    for (const auto& f : *it) {
      if (!f.is_object()) continue;
      Finding finding;
      finding.effect = f.value("effect", std::string());
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
