// The headline figures of a result (headlines.hpp): the few numbers of a PARAMS that say how a machine is.
#include "fleet/headlines.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/number_format.hpp"
#include "results/parameters.hpp"
#include "results/session_kinds.hpp"

namespace guideway::fleet {

namespace {

// Where the catalogue says a figure is: in its group under its name (or its figure_name), else in the groups it is
// also reported in, under its name there (a DBB backlash: Lai's, his x and y the plane's axes).
using Found = std::pair<std::string_view, const results::Figure*>;  // the group, and the figure in it
std::vector<Found> figures_of(const results::Parameter& p, const std::string& plane, int axis,
                              const results::Params& params) {
  std::vector<Found> out;
  const auto look = [&](std::string_view group, const std::string& name) {
    if (const results::Figure* f = params.find(group, name)) out.emplace_back(group, f);
  };
  if (!p.group.empty())
    look(p.group, p.figure_name.empty() ? results::name(p, plane, axis) : std::string(p.figure_name));
  for (const results::Place& place : p.places) look(place.group, results::name_in(p, place.group, plane, axis));
  return out;
}

std::optional<double> finite(double v) { return std::isfinite(v) ? std::optional<double>(v) : std::nullopt; }

std::optional<Headline> figure(const results::Parameter& p, const std::string& plane, int axis,
                               const results::Params& params) {
  const std::string name = results::name(p, plane, axis);
  for (const auto& [group, f] : figures_of(p, plane, axis, params)) {
    if (std::isfinite(f->value))
      return Headline{name, results::label(p, plane, axis), results::unit(p), f->value,
                      f->u ? finite(*f->u) : std::nullopt};
  }
  return std::nullopt;
}

// The DBB figures are named after the plane's axes ("xy": x and y; "zx": z and x); "xy" when the
// result names no plane (or one that is not two axis letters: such a result is refused at ingest).
std::string plane_of(const results::Params& params) {
  const std::string& plane = params.plane;
  const auto axis = [](char c) { return c == 'x' || c == 'y' || c == 'z'; };
  if (plane.size() == 2 && axis(plane[0]) && axis(plane[1]) && plane[0] != plane[1]) return plane;
  return "xy";
}

std::vector<int> axes_of(const results::Parameter& p) {
  return results::per_axis(p) ? std::vector<int>{0, 1} : std::vector<int>{-1};
}

}  // namespace

std::vector<Headline> headlines(std::string_view kind, const results::Params& params) {
  const std::string plane = plane_of(params);
  std::vector<Headline> out;
  for (const results::Parameter* p : results::headline_parameters(kind)) {
    for (const int axis : axes_of(*p))
      if (auto h = figure(*p, plane, axis, params)) out.push_back(std::move(*h));
  }
  return out;
}

std::string figure_problem(std::string_view kind, const results::Params& params) {
  const std::string plane = plane_of(params);
  for (const results::Parameter* p : results::headline_parameters(kind)) {
    for (const int axis : axes_of(*p)) {
      for (const auto& [group, f] : figures_of(*p, plane, axis, params)) {
        for (const auto& [what, v] : {std::pair{"value", f->value}, std::pair{"u", f->u.value_or(0.0)}})
          if (!std::isfinite(v))
            return "the figure " + std::string(group) + "." + f->name + " has " + what + " " +
                   (std::isnan(v) ? "null" : "infinite") + ", expected a finite number";
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
