// The headline figures of a result (headlines.hpp): the few numbers of a PARAMS that say how a machine is.
#include "fleet/headlines.hpp"

#include <algorithm>
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

// Where the catalogue says a figure's value and u are: its own pointers, else an estimate object
// {"value": v, "u": u} in its group (models/dbb/json.cpp, the sessions' figure groups), else in the group
// it is also reported in.
std::vector<std::pair<std::string, std::string>> figure_pointers(const results::Parameter& p, const std::string& name) {
  if (!p.value_at.empty()) return {{std::string(p.value_at), std::string(p.u_at)}};
  std::vector<std::pair<std::string, std::string>> out;
  for (const std::string_view group : {p.group, p.also_in}) {
    if (group.empty()) continue;
    const std::string at = "/" + std::string(group) + "/" + name;
    out.emplace_back(at + "/value", at + "/u");
  }
  return out;
}

std::optional<Headline> figure(const results::Parameter& p, const std::string& plane, int axis,
                               const nlohmann::json& params) {
  const std::string name = results::name(p, plane, axis);
  for (const auto& [value_at, u_at] : figure_pointers(p, name)) {
    if (const auto v = number_at(params, value_at))
      return Headline{name, results::label(p, plane, axis), results::unit(p), *v, number_at(params, u_at)};
  }
  return std::nullopt;
}

// The DBB figures are named after the plane's axes ("xy": x and y; "zx": z and x); "xy" when the
// object names no plane (or one that is not two axis letters: such a result is refused at ingest).
std::string plane_of(const nlohmann::json& params) {
  if (const auto it = params.find("plane"); it != params.end() && it->is_string()) {
    const auto& plane = it->get_ref<const std::string&>();
    const auto axis = [](char c) { return c == 'x' || c == 'y' || c == 'z'; };
    if (plane.size() == 2 && axis(plane[0]) && axis(plane[1]) && plane[0] != plane[1]) return plane;
  }
  return "xy";
}

std::vector<int> axes_of(const results::Parameter& p) {
  return results::per_axis(p) ? std::vector<int>{0, 1} : std::vector<int>{-1};
}

}  // namespace

std::vector<Headline> headlines(std::string_view kind, const nlohmann::json& params) {
  const std::string plane = plane_of(params);
  std::vector<Headline> out;
  for (const results::Parameter* p : results::headline_parameters(kind)) {
    for (const int axis : axes_of(*p))
      if (auto h = figure(*p, plane, axis, params)) out.push_back(std::move(*h));
  }
  return out;
}

std::string figure_problem(std::string_view kind, const nlohmann::json& params) {
  const std::string plane = plane_of(params);
  for (const results::Parameter* p : results::headline_parameters(kind)) {
    for (const int axis : axes_of(*p)) {
      for (const auto& [value_at, u_at] : figure_pointers(*p, results::name(*p, plane, axis))) {
        for (const auto& pointer : {value_at, u_at}) {
          if (pointer.empty()) continue;
          const nlohmann::json::json_pointer jp(pointer);
          if (!params.contains(jp)) continue;
          const auto& v = params.at(jp);
          if (!v.is_number() || !std::isfinite(v.get<double>()))
            return "the figure at " + pointer + " is " + (v.is_number() ? "not finite" : std::string(v.type_name())) +
                   ", expected a finite number";
        }
      }
    }
  }
  return {};
}

std::string found_text(const results::Explanation& e) {
  if (!e.not_analysed.empty()) return "not analysed";
  // Largest first, as EXPLAIN's own text lists them ("what to fix first"); in the order found for equal sizes.
  std::vector<const results::ExplainFinding*> ranked;
  for (const auto& f : e.findings) ranked.push_back(&f);
  std::stable_sort(ranked.begin(), ranked.end(),
                   [](const results::ExplainFinding* a, const results::ExplainFinding* b) {
                     return (std::isfinite(a->contribution_um) ? a->contribution_um : -1.0) >
                            (std::isfinite(b->contribution_um) ? b->contribution_um : -1.0);
                   });
  std::string out;
  for (const results::ExplainFinding* f : ranked) {
    if (!out.empty()) out += ", ";
    out += results::in_words(f->effect);
    if (std::isfinite(f->contribution_um)) out += " " + significant_digits(f->contribution_um, 3) + " µm";
  }
  if (out.empty()) out = "nothing found";
  if (e.unexplained) out += out == "nothing found" ? "; unexplained" : "; rest unexplained";
  return out;
}

bool moved(const Headline& latest, const Headline& previous) {
  if (!latest.u || !previous.u) return false;
  const double u = std::sqrt(*latest.u * *latest.u + *previous.u * *previous.u);
  return std::abs(latest.value - previous.value) > moved_coverage_factor * u;
}

}  // namespace guideway::fleet
