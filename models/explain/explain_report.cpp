// An EXPLAIN report as JSON and as text (explain_result.hpp): findings, locations, notes and held-out figures.
#include "models/explain/explain_result.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/number_format.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain {

namespace {

// Rounded for the JSON: curves for plots need no more than 4 decimals (0.1 nm; 1e-4 deg or mm), and stay
// compact. Divided by an exact power of ten, so the shortest decimal form is printed.
double rounded4(double v) { return std::isfinite(v) ? std::round(v * 1e4) / 1e4 : v; }

std::string unit_of_domain(const std::string& domain) { return domain == "angle_deg" ? "deg" : "mm"; }

// One location in words: the run (file), the place, the times from the run's start and on the machine
// clock, the size, and whether it repeats.
std::string location_text(const Location& l, const std::string& domain) {
  const auto g = [](double v, const char* f) { return printf_number(f, v); };
  std::string s = l.run + (l.source.empty() ? "" : " [" + l.source + "]") + ": " + g(l.where.first, "%.4g") + ".." +
                  g(l.where.second, "%.4g") + " " + unit_of_domain(domain) + ", ";
  if (l.timed)
    s += g(l.t_from_run_start_s.first, "%.2f") + ".." + g(l.t_from_run_start_s.second, "%.2f") + " s from its start";
  else  // no times recorded: the readings' order, counted from its first (0)
    s += "readings " + g(l.t_from_run_start_s.first, "%.0f") + ".." + g(l.t_from_run_start_s.second, "%.0f") +
         " of it (no times recorded)";
  if (std::isfinite(l.t_machine_s.first))
    s += " (machine clock " + g(l.t_machine_s.first, "%.2f") + ".." + g(l.t_machine_s.second, "%.2f") + " s)";
  s += ", " + g(l.peak_um, "%+.3g") + " um, ";
  if (l.repeats_in.empty()) {
    s += "once (no other run has it at this place)";
  } else {
    s += "repeats in";
    for (const auto& r : l.repeats_in) s += " " + r;
  }
  if (l.set_aside) s += "; set aside from the fit of the findings";
  return s;
}

}  // namespace

nlohmann::json to_json(const Report& r) {
  using nlohmann::json;
  const auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  const auto stats = [&](const FitStats& f) {
    return json{{"rms_um", num(f.rms_um)},
                {"bic", num(f.bic)},
                {"heldout_rms_um", num(f.heldout_rms_um)},
                {"parameters", f.parameters}};
  };
  const auto places = [&](const std::vector<Mismatch>& v) {
    json a = json::array();
    for (const auto& m : v) {
      json ranges = json::array();
      for (const auto& [lo, hi] : m.ranges) ranges.push_back({lo, hi});
      json place{
          {"domain", m.domain}, {"where", m.where}, {"band", m.band}, {"evidence", m.evidence}, {"ranges", ranges}};
      if (!m.locations.empty()) {
        json locs = json::array();
        const auto pair = [&](std::pair<double, double> p) {
          return json::array({num(rounded4(p.first)), num(rounded4(p.second))});
        };
        for (const auto& l : m.locations) {
          locs.push_back({{"run", l.run},
                          {"source", l.source},
                          {"where", pair(l.where)},
                          {"t_machine_s", pair(l.t_machine_s)},
                          {"peak_um", num(rounded4(l.peak_um))},
                          {"once", l.repeats_in.empty()},
                          {"repeats_in", l.repeats_in},
                          {"set_aside", l.set_aside}});
          // Without times, the readings' order from the run's first (0), never seconds.
          locs.back()[l.timed ? "t_from_run_start_s" : "readings_from_run_start"] = pair(l.t_from_run_start_s);
        }
        place["locations"] = locs;
      }
      a.push_back(std::move(place));
    }
    return a;
  };
  json j;
  j["model"] = r.model;
  j["n"] = r.n;
  if (r.set_aside > 0) j["set_aside_samples"] = r.set_aside;
  j["noise_um"] = num(r.noise_um);
  j["heldout_scheme"] = r.heldout_scheme;
  j["baseline"] = stats(r.baseline);
  j["mismatch"] = places(r.mismatch);
  json f = json::array();
  for (const auto& fd : r.findings) {
    json p = json::object();
    for (const auto& q : fd.parameters) p[q.name] = {{"value", num(q.value)}, {"u", num(q.u)}};
    f.push_back({{"effect", fd.effect},
                 {"parameters", p},
                 {"delta_bic", num(fd.delta_bic)},
                 {"p_value", num(fd.p_value)},
                 {"rms_um_after", num(fd.rms_um_after)},
                 {"heldout_rms_um_after", num(fd.heldout_rms_um_after)},
                 {"structure_removed", num(fd.share)},
                 {"contribution_um", num(fd.contribution_um)},
                 {"percent_of_deviation", num(fd.contribution_percent)},
                 {"why", fd.why}});
  }
  j["findings"] = f;
  j["final"] = stats(r.final_fit);
  j["unexplained"] = r.unexplained;
  if (std::isfinite(r.deviation_um)) j["deviation"] = {{"name", r.deviation_name}, {"value_um", r.deviation_um}};
  j["remaining"] = places(r.remaining);
  json c = json::array();
  for (const auto& k : r.considered)
    c.push_back(
        {{"effect", k.effect}, {"delta_bic", num(k.delta_bic)}, {"p_value", num(k.p_value)}, {"verdict", k.verdict}});
  j["considered"] = c;
  j["notes"] = r.notes;
  if (!r.curve_x.empty()) {
    const auto round_all = [](const std::vector<double>& v) {
      json a = json::array();
      for (double e : v) a.push_back(rounded4(e));
      return a;
    };
    json steps = json::array();
    for (const auto& st : r.curve_steps) {
      json runs = json::array();
      for (const auto& v : st.residual_um) runs.push_back(round_all(v));
      steps.push_back({{"label", st.label}, {"residual_um", runs}});
    }
    j["residuals"] = {
        {"domain", r.curve_domain}, {"x", round_all(r.curve_x)}, {"runs", r.curve_runs}, {"steps", steps}};
  }
  return j;
}

std::string to_text(const Report& r) {
  std::ostringstream o;
  const auto g = [](double v, const char* f = "%.4g") { return printf_number(f, v); };
  o << "model " << r.model << ": " << r.n << " samples, noise " << g(r.noise_um, "%.3g")
    << " \u00b5m (finest wavelet details)\n";
  o << "baseline: rms " << g(r.baseline.rms_um, "%.3g") << " \u00b5m, held-out rms "
    << g(r.baseline.heldout_rms_um, "%.3g") << " \u00b5m, BIC " << g(r.baseline.bic, "%.1f") << "  ["
    << r.heldout_scheme << "]\n";
  if (r.mismatch.empty()) {
    o << "\nwhere: the baseline residual is indistinguishable from noise (band energies, runs test, Ljung-Box).\n";
  } else {
    o << "\nwhere the residual is not noise:\n";
    for (const auto& m : r.mismatch) {
      o << "  - " << m.domain << ": " << m.where << "\n      band " << m.band << "\n      " << m.evidence << "\n";
      for (const auto& l : m.locations) o << "      at " << location_text(l, m.domain) << "\n";
    }
  }
  if (r.findings.empty()) {
    o << "\nfindings: none of the candidate effects is significant.\n";
  } else {
    o << "\nfindings (in the order they were taken):\n";
    int k = 1;
    for (const auto& f : r.findings) {
      o << "  " << k++ << ". " << results::in_words(f.effect) << ": " << f.why << "\n";
      for (const auto& p : f.parameters) {
        const results::Shown v = results::shown(p.name, p.value, p.u);
        o << "       " << v.label << " " << v.value << (v.unit.empty() ? "" : " " + v.unit)
          << (std::isfinite(p.u) ? "" : " (searched)") << "\n";
      }
      o << "       BIC " << g(f.delta_bic, "%+.1f") << ", p = " << g(f.p_value, "%.2g") << ", rms -> "
        << g(f.rms_um_after, "%.3g") << " \u00b5m, held-out rms -> " << g(f.heldout_rms_um_after, "%.3g") << " \u00b5m";
      if (std::isfinite(f.share))
        o << ", removes " << g(100 * f.share, "%.0f") << " % of the structure left without it";
      o << "\n";
    }
    // What to fix first: the findings by the size of their term in the readings.
    std::vector<const Finding*> ranked;
    for (const auto& f : r.findings) ranked.push_back(&f);
    std::stable_sort(ranked.begin(), ranked.end(),
                     [](const Finding* a, const Finding* b) { return a->contribution_um > b->contribution_um; });
    o << "\nlargest first (peak-to-valley of each term";
    if (std::isfinite(r.deviation_um)) o << "; " << r.deviation_name << " " << g(r.deviation_um, "%.3g") << " \u00b5m";
    o << "):\n";
    for (const Finding* f : ranked) {
      o << "  " << results::in_words(f->effect) << ": " << g(f->contribution_um, "%.3g") << " \u00b5m";
      if (std::isfinite(f->contribution_percent)) o << " (" << g(f->contribution_percent, "%.0f") << " %)";
      o << "\n";
    }
  }
  if (!r.considered.empty()) {
    o << "\nnot taken:\n";
    for (const auto& c : r.considered) o << "  " << results::in_words(c.effect) << ": " << c.verdict << "\n";
  }
  o << "\nfinal: rms " << g(r.final_fit.rms_um, "%.3g") << " \u00b5m, held-out rms "
    << g(r.final_fit.heldout_rms_um, "%.3g") << " \u00b5m, BIC " << g(r.final_fit.bic, "%.1f") << "\n";
  if (r.unexplained) {
    o << "UNEXPLAINED: the residual is still structured and no effect in the library accounts for it:\n";
    for (const auto& m : r.remaining) {
      o << "  - " << m.domain << ": " << m.where << " (" << m.evidence << ")\n";
      for (const auto& l : m.locations) o << "      at " << location_text(l, m.domain) << "\n";
    }
  } else {
    o << "the remaining residual is consistent with noise.\n";
  }
  for (const auto& n : r.notes) o << "note: " << n << "\n";
  return o.str();
}

}  // namespace guideway::models::explain
