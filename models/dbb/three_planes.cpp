// The machine across its test planes (three_planes.hpp): several planes' identifications brought together, axis by
// axis.
#include "models/dbb/three_planes.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "core/number_format.hpp"
#include "results/parameters.hpp"

namespace guideway::models::dbb {

namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

const Estimate* find(const std::vector<Estimate>& list, const std::string& name) {
  for (const auto& e : list)
    if (e.name == name && e.fitted) return &e;
  return nullptr;
}

// A plane's figure of its axis `axis` (0, 1): the diagnostics' when they hold it, else Lai's `lai_a` or `lai_b`
// (its x and y are the plane's axes), converted by `from_lai` into the diagnostics' unit.
template <class FromLai>
const Estimate* axis_estimate(const Identification& id, const results::Parameter& diag, const std::string& lai_a,
                              const std::string& lai_b, int axis, Estimate& scratch, const FromLai& from_lai) {
  if (const Estimate* e = find(id.diagnostics, results::name(diag, id.plane, axis))) return e;
  const Estimate* l = find(id.lai3, axis == 0 ? lai_a : lai_b);
  if (!l) return nullptr;
  scratch = {results::name(diag, id.plane, axis), from_lai(l->value), std::abs(from_lai(l->u) - from_lai(0.0)), true};
  return &scratch;
}

std::string figure_text(const std::string& name, double value, double u) {
  return with_uncertainty(value, u, 3) + " " + results::split_unit(name).second;
}

// The planes' figures of one axis, their weighted mean and whether they agree.
AxisFigure combine(const std::string& name, const std::string& axis, std::vector<PlaneFigure> from) {
  AxisFigure f{name, axis, std::move(from)};
  double sw = 0, swx = 0;
  bool all_u = true;
  for (const auto& p : f.from) {
    if (!(p.u > 0) || !std::isfinite(p.u)) {
      all_u = false;
      continue;
    }
    sw += 1 / (p.u * p.u);
    swx += p.value / (p.u * p.u);
  }
  if (all_u && sw > 0) {
    f.value = swx / sw;
    f.u = 1 / std::sqrt(sw);
  } else {
    double s = 0;
    for (const auto& p : f.from) s += p.value;
    f.value = s / static_cast<double>(f.from.size());
    f.u = nan;
  }
  for (std::size_t i = 0; i < f.from.size(); ++i)
    for (std::size_t k = i + 1; k < f.from.size(); ++k) {
      const PlaneFigure &a = f.from[i], &b = f.from[k];
      if (figures_agree(a.value, a.u, b.value, b.u)) continue;
      f.consistent = false;
      std::ostringstream o;
      o << results::label_of(name, a.plane) << ": the " << a.plane << " plane gives " << figure_text(name, a.value, a.u)
        << ", the " << b.plane << " plane " << figure_text(name, b.value, b.u) << "; they differ by "
        << shortest(std::round(std::abs(a.value - b.value) * 100) / 100)
        << ", more than twice their combined uncertainty ("
        << shortest(std::round(2 * std::hypot(a.u, b.u) * 100) / 100) << ")";
      f.note += (f.note.empty() ? "" : "; ") + o.str();
    }
  return f;
}

}  // namespace

std::vector<std::vector<formats::DbbRun>> runs_by_plane(std::vector<formats::DbbRun> runs) {
  std::vector<std::vector<formats::DbbRun>> out;
  for (auto& run : runs) {
    auto it = std::find_if(out.begin(), out.end(), [&](const auto& g) { return g.front().plane == run.plane; });
    if (it == out.end()) it = out.insert(out.end(), std::vector<formats::DbbRun>{});
    it->push_back(std::move(run));
  }
  return out;
}

bool figures_agree(double a, double ua, double b, double ub) {
  if (!std::isfinite(ua) || !std::isfinite(ub)) return true;  // nothing to judge by
  return std::abs(a - b) <= 2 * std::hypot(ua, ub);
}

PlanesSummary summarize_planes(const std::vector<Identification>& ids) {
  if (ids.empty()) throw std::invalid_argument("summary of the planes: no identification given");
  PlanesSummary out;
  for (const auto& id : ids) {
    if (std::find(out.planes.begin(), out.planes.end(), id.plane) != out.planes.end())
      throw std::invalid_argument("summary of the planes: plane " + id.plane +
                                  " given twice (identify its runs together)");
    out.planes.push_back(id.plane);
  }
  for (const char* p : {"xy", "xz", "yz"})
    if (std::find(out.planes.begin(), out.planes.end(), p) == out.planes.end())
      out.notes.push_back(std::string("no ") + p + " plane: its squareness and scale mismatch are not known");
  // Per plane: squareness and scale mismatch.
  for (const auto& id : ids) {
    const std::string square_name = results::name_in(results::squareness, results::planes_group, id.plane);
    if (const Estimate* q = find(id.diagnostics, results::name(results::squareness))) {
      out.squareness.push_back({square_name, q->value, q->u, true});
    } else if (const Estimate* a1 = find(id.lai3, std::string(results::lai_a1.name))) {
      out.squareness.push_back({square_name, a1->value * 1e6, a1->u * 1e6, true});
    } else {
      out.notes.push_back("the " + id.plane + " plane's runs do not give its squareness");
    }
    if (const Estimate* m = find(id.diagnostics, results::name(results::scale_mismatch)))
      out.scale_mismatch.push_back(
          {results::name_in(results::scale_mismatch, results::planes_group, id.plane), m->value, m->u, true});
    else
      out.notes.push_back("the " + id.plane + " plane's runs do not give its scale mismatch");
  }
  // Per axis: backlash and scale from every plane that has the axis (Lai's: his x and y, the plane's two axes).
  const std::string lai_backlash[] = {results::name_in(results::backlash, results::lai3_group, "xy", 0),
                                      results::name_in(results::backlash, results::lai3_group, "xy", 1)};
  const std::string lai_scale[] = {std::string(results::lai_S_x.name), std::string(results::lai_S_y.name)};
  for (const std::string axis : {"x", "y", "z"}) {
    const std::string first_of = axis + (axis == "x" ? "y" : "x");  // a plane whose first axis it is
    std::vector<PlaneFigure> backlash, scale;
    for (const auto& id : ids) {
      const int k =
          results::axis_letter(id.plane, 0) == axis ? 0 : (results::axis_letter(id.plane, 1) == axis ? 1 : -1);
      if (k < 0) continue;
      Estimate scratch;
      if (const Estimate* b = axis_estimate(id, results::backlash, lai_backlash[0], lai_backlash[1], k, scratch,
                                            [](double v) { return v; }))
        backlash.push_back({id.plane, b->value, b->u});
      if (const Estimate* s = axis_estimate(id, results::scale, lai_scale[0], lai_scale[1], k, scratch,
                                            [](double v) { return (v - 1.0) * 1e6; }))
        scale.push_back({id.plane, s->value, s->u});
    }
    if (!backlash.empty())
      out.backlash.push_back(
          combine(results::name_in(results::backlash, results::planes_group, first_of, 0), axis, std::move(backlash)));
    if (!scale.empty())
      out.scale.push_back(
          combine(results::name_in(results::scale, results::planes_group, first_of, 0), axis, std::move(scale)));
  }
  for (const auto* list : {&out.backlash, &out.scale})
    for (const auto& f : *list)
      if (!f.consistent) out.notes.push_back(f.note);
  if (!out.scale.empty())
    out.notes.push_back(
        "an axis' scale carries what is common to its plane's two axes (a radius change: the position loops' lag at "
        "speed, the bar's calibration); the scale mismatches are the axes' own differences");
  // Every plane's ranking, against the largest G of them all.
  for (const auto& id : ids)
    for (const auto& r : id.runs)
      out.circular_deviation_um = std::max(out.circular_deviation_um, r.circular_deviation_um);
  for (const auto& id : ids)
    for (const auto& c : id.ranking)
      out.ranking.push_back(
          {id.plane, c.name, c.contribution_um,
           out.circular_deviation_um > 0 ? 100 * c.contribution_um / out.circular_deviation_um : nan});
  std::stable_sort(out.ranking.begin(), out.ranking.end(), [](const PlaneContribution& a, const PlaneContribution& b) {
    return a.contribution_um > b.contribution_um;
  });
  return out;
}

}  // namespace guideway::models::dbb
