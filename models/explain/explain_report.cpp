// An EXPLAIN report as the results' explanation (explanation.hpp; its JSON is results/explanation.cpp's) and as
// text (explain_result.hpp): findings, locations, notes and held-out figures.
#include "models/explain/explanation.hpp"

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

results::Explanation explanation_of(const Report& r) {
  const auto pair = [](std::pair<double, double> p) { return std::pair{rounded4(p.first), rounded4(p.second)}; };
  const auto places = [&](const std::vector<Mismatch>& v) {
    std::vector<results::ExplainPlace> out;
    for (const auto& m : v) {
      results::ExplainPlace place{m.domain, m.where, m.band, m.evidence, m.ranges, {}};
      for (const auto& l : m.locations)
        place.locations.push_back({l.run, l.source, pair(l.where), pair(l.t_from_run_start_s), l.timed,
                                   pair(l.t_machine_s), rounded4(l.peak_um), l.repeats_in, l.set_aside});
      out.push_back(std::move(place));
    }
    return out;
  };
  const auto fit = [](const FitStats& f) {
    return results::ExplainFit{f.rms_um, f.bic, f.heldout_rms_um, f.parameters};
  };
  results::Explanation e;
  e.model = r.model;
  e.n = r.n;
  e.set_aside_samples = r.set_aside;
  e.noise_um = r.noise_um;
  e.heldout_scheme = r.heldout_scheme;
  e.baseline = fit(r.baseline);
  e.mismatch = places(r.mismatch);
  for (const auto& fd : r.findings) {
    results::ExplainFinding f;
    f.effect = fd.effect;
    // One value per name, the last given (as a JSON object keeps it).
    for (const auto& q : fd.parameters) f.parameters.insert_or_assign(q.name, results::ExplainEstimate{q.value, q.u});
    f.delta_bic = fd.delta_bic;
    f.p_value = fd.p_value;
    f.rms_um_after = fd.rms_um_after;
    f.heldout_rms_um_after = fd.heldout_rms_um_after;
    f.structure_removed = fd.share;
    f.contribution_um = fd.contribution_um;
    f.percent_of_deviation = fd.contribution_percent;
    f.why = fd.why;
    e.findings.push_back(std::move(f));
  }
  e.final_fit = fit(r.final_fit);
  e.unexplained = r.unexplained;
  if (std::isfinite(r.deviation_um)) e.deviation = results::ExplainDeviation{r.deviation_name, r.deviation_um};
  e.remaining = places(r.remaining);
  for (const auto& k : r.considered) e.considered.push_back({k.effect, k.delta_bic, k.p_value, k.verdict});
  e.notes = r.notes;
  if (!r.curve_x.empty()) {
    const auto round_all = [](std::vector<double> v) {
      for (double& x : v) x = rounded4(x);
      return v;
    };
    results::ExplainResiduals curves{r.curve_domain, round_all(r.curve_x), r.curve_runs, {}};
    for (const auto& st : r.curve_steps) {
      results::ExplainResidualStep step{st.label, {}};
      for (const auto& v : st.residual_um) step.residual_um.push_back(round_all(v));
      curves.steps.push_back(std::move(step));
    }
    e.residuals = std::move(curves);
  }
  return e;
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
