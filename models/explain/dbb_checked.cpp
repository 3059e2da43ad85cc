// DBB runs identified and checked by EXPLAIN (dbb_checked.hpp): what the CLI and the live DBB session share.
#include "models/explain/dbb_checked.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <span>

#include "core/number_format.hpp"
#include "models/dbb/json.hpp"
#include "models/explain/dbb_explain.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain {

namespace {

const dbb::Estimate* find(const std::vector<dbb::Estimate>& items, const std::string& name) {
  for (const auto& e : items)
    if (e.name == name) return &e;
  return nullptr;
}

// A term contradicts another identification of the same runs when they differ by more than this many
// combined standard uncertainties.
constexpr double contradiction_k = 3.0;

}  // namespace

std::string contradiction(const dbb::Estimate& term, const std::vector<dbb::Estimate>& others) {
  const auto* other = find(others, term.name);
  if (!other || !std::isfinite(other->u) || !std::isfinite(term.u)) return "";
  const double z = std::abs(term.value - other->value) / std::hypot(term.u, other->u);
  if (!(z > contradiction_k)) return "";
  return "contradicts EXPLAIN's " + printf_number("%.4g", other->value) + " +/- " + printf_number("%.2g", other->u) +
         " on the same runs (" + printf_number("%.0f", z) + " combined u apart)";
}

namespace {

// EXPLAIN's effects that identify's models hold themselves, so never fitted beside them: both models hold
// the backlash and the servo mismatch, the diagnostics also the spikes, the lateral play and a cyclic error
// (those are fitted beside Lai's terms only).
constexpr std::string_view held_by_both[] = {"backlash", "servo_mismatch"};
constexpr std::string_view held_by_diagnostics[] = {"reversal_spike", "lateral_play", "cyclic_error"};
// Not fitted beside either, with the reason: servo_lag is the geometry itself seen one lag earlier along
// the path, a column built from the base's fit whose shapes the diagnostics' servo mismatch and scale share.
constexpr std::string_view not_beside[] = {"servo_lag"};

bool listed_in(std::span<const std::string_view> list, const std::string& effect) {
  return std::find(list.begin(), list.end(), effect) != list.end();
}

// identify with options.beside, and what was fitted beside as the checked identification reports it.
void identify_beside(const std::vector<formats::DbbRun>& runs, const dbb::IdentifyOptions& options,
                     CheckedIdentification& out) {
  out.id = dbb::identify(runs, options);
  out.beside_terms = options.beside;
  for (const auto& t : options.beside)
    for (std::size_t c = 0; c < t.columns_um.size() && c < t.names.size(); ++c)
      if (const auto* e = find(out.id.beside, t.names[c])) {
        out.beside_um.resize(t.columns_um[c].size(), 0.0);
        for (std::size_t i = 0; i < out.beside_um.size(); ++i) out.beside_um[i] += e->value * t.columns_um[c][i];
      }
  // The effects actually fitted beside the terms reported (the diagnostics hold a cyclic error themselves).
  for (const auto& t : options.beside)
    if (std::any_of(t.names.begin(), t.names.end(), [&](const std::string& n) { return find(out.id.beside, n); }))
      out.beside.push_back(t.effect);
  if (!out.beside.empty()) {
    std::string list, values;
    for (const auto& e : out.beside) list += (list.empty() ? "" : ", ") + e;
    for (const auto& e : out.id.beside) {
      // A line as its amplitude and phase, not its sine and cosine parts.
      if (const auto line = results::line_of_part(e.name); line && find(out.id.beside, line->amplitude)) continue;
      values += (values.empty() ? "" : ", ") + e.name + " " + printf_number("%.4g", e.value) + " +/- " +
                printf_number("%.2g", e.u);
    }
    out.notes.push_back(std::string(fitted_beside_note) + ", as EXPLAIN found them on the same runs: " + list + " (" +
                        values + "); not in any table");
  }
}

// Whether two lists of runs share their sample grid: the same runs, angles and times (a retrace of runs
// simulated from the same machine file).
bool same_grid(const std::vector<formats::DbbRun>& a, const std::vector<formats::DbbRun>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t k = 0; k < a.size(); ++k) {
    if (a[k].angle_rad.size() != b[k].angle_rad.size() || a[k].direction != b[k].direction) return false;
    for (std::size_t i = 0; i < a[k].angle_rad.size(); ++i)
      if (std::abs(a[k].angle_rad[i] - b[k].angle_rad[i]) > 1e-9 || std::abs(a[k].t_s[i] - b[k].t_s[i]) > 1e-9)
        return false;
  }
  return true;
}

}  // namespace

namespace {
std::atomic<std::size_t> identify_checked_calls{0};
}  // namespace

std::size_t identify_checked_count() { return identify_checked_calls.load(std::memory_order_relaxed); }

CheckedIdentification identify_checked(const std::vector<formats::DbbRun>& runs, const dbb::IdentifyOptions& options,
                                       const ExplainOptions& explain) {
  identify_checked_calls.fetch_add(1, std::memory_order_relaxed);
  ExplainOptions eo = explain;
  eo.keep_columns = true;
  CheckedIdentification out;
  Report report;
  try {
    report = explain_dbb_report(runs, eo);
  } catch (const std::exception& e) {
    // Runs EXPLAIN refuses (too short, a gap too wide) are still the models' to identify: alone, said so.
    out.id = dbb::identify(runs, options);
    out.notes.push_back(std::string("EXPLAIN could not run on these runs (") + e.what() +
                        "): the models' terms alone, nothing fitted beside them");
    return out;
  }
  dbb::IdentifyOptions o = options;
  for (const auto& f : report.findings) {
    for (const auto& p : f.parameters)
      if (std::isfinite(p.u)) out.explain.push_back({p.name, p.value, p.u, true});
    if (listed_in(held_by_both, f.effect)) continue;
    if (listed_in(not_beside, f.effect)) {
      out.notes.push_back("EXPLAIN found " + f.effect +
                          " on these runs; it is not fitted beside the terms (it is the geometry itself seen one lag "
                          "earlier along the path, which the scale and servo mismatch partly take)");
      continue;
    }
    o.beside.push_back({f.effect, f.column_names, f.columns_um, !listed_in(held_by_diagnostics, f.effect)});
  }
  identify_beside(runs, o, out);
  out.explanation = explanation_of(report);
  return out;
}

CheckedIdentification identify_checked_like(const std::vector<formats::DbbRun>& runs,
                                            const CheckedIdentification& earlier,
                                            const std::vector<formats::DbbRun>& earlier_runs) {
  if (!same_grid(runs, earlier_runs)) return identify_checked(runs);
  CheckedIdentification out;
  out.explain = earlier.explain;
  dbb::IdentifyOptions o;
  o.beside = earlier.beside_terms;
  identify_beside(runs, o, out);
  return out;
}

results::Params to_params(const CheckedIdentification& checked) {
  results::Params p = dbb::to_params(checked.id);
  std::vector<std::string>& notes = p.dbb->notes;  // dbb::to_params gives every identification its record
  std::string beside;
  for (const auto& e : checked.beside) beside += (beside.empty() ? "" : ", ") + results::in_words(e);
  const auto mark = [&](const std::vector<dbb::Estimate>& terms, std::string_view group) {
    for (const auto& e : terms) {
      const std::string why = contradiction(e, checked.explain);
      if (why.empty()) continue;
      for (results::Figure& f : p.group_named(group).figures)
        if (f.name == e.name) f.not_determined = why;
      const dbb::Estimate* other = find(checked.explain, e.name);
      const results::Shown mine = results::shown(e.name, e.value, e.u, checked.id.plane, group);
      const results::Shown theirs = results::shown(e.name, other->value, other->u, checked.id.plane, group);
      notes.push_back(mine.label + " is not determined: " + mine.value + " " + mine.unit + ", where EXPLAIN finds " +
                      theirs.value + " " + theirs.unit + " on the same runs" +
                      (beside.empty() ? std::string() : ", with " + beside + " fitted beside"));
    }
  };
  mark(checked.id.diagnostics, "diagnostics");
  mark(checked.id.lai3, "lai3");
  for (const auto& n : checked.notes) {
    // The values fitted beside are in their own group, in words: the note says only what they are.
    if (n.starts_with(fitted_beside_note))
      notes.push_back(
          "what EXPLAIN found on the same runs and the models do not hold is fitted beside "
          "their terms (above), so that it is not read as one of them: " +
          beside);
    else
      notes.push_back(n);
  }
  return p;
}

nlohmann::json to_json(const CheckedIdentification& checked) { return results::to_json(to_params(checked)); }

}  // namespace guideway::models::explain
