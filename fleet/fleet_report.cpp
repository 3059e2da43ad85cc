// The fleet report (fleet_report.hpp): one self-contained HTML page of the plant's machines.
#include "fleet/fleet_report.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>

#include "core/number_format.hpp"
#include "core/utc_time.hpp"
#include "fleet/fleet_status.hpp"
#include "fleet/history.hpp"
#include "report/html.hpp"
#include "report/svg.hpp"

namespace guideway::fleet {

namespace {

constexpr double seconds_per_day = 86400.0;

// An HTML id from a machine name, one per name: letters, digits and '_' as they are, every other byte
// as '-' and its two hex digits ("mill.1" -> machine-mill-2e1, "mill-1" -> machine-mill-2d1).
std::string anchor(const std::string& machine) {
  static constexpr char hex[] = "0123456789abcdef";
  std::string id = "machine-";
  for (const char c : machine) {
    const auto b = static_cast<unsigned char>(c);
    if (std::isalnum(b) || c == '_') {
      id += c;
    } else {
      id += '-';
      id += hex[b >> 4];
      id += hex[b & 15];
    }
  }
  return id;
}

// A cell that a narrow page does not break inside ("1.1564 ± 0.0080").
std::string nowrap(const std::string& html) { return "<span style=\"white-space:nowrap\">" + html + "</span>"; }

std::string figure_cell(const FigureChange* f) {
  if (!f) return "–";
  std::string cell = report::html_escape(with_uncertainty(f->latest.value, f->latest.u.value_or(std::nan("")), 5));
  if (f->moved) cell = "<strong class=\"moved\">" + cell + " *</strong>";
  return nowrap(cell);
}

// "2026-11-25T09:00:12.5Z" as "2026-11-25 09:00" on one line; "" stays "".
std::string utc_minutes_html(const std::string& iso) {
  if (iso.size() < 16) return report::html_escape(iso);
  return nowrap(report::html_escape(iso.substr(0, 10) + " " + iso.substr(11, 5)));
}

// When a result was made, as a page read days later needs it: the date and time, and how long before
// the report that was ("2026-11-25 09:00, 1.2 d before this report").
std::string when_made(double made_s, double report_s) {
  const double age = report_s - made_s;
  return utc_minutes_html(utc_iso_ms(made_s)) + ", " +
         report::html_escape(age < 0 ? "after this report" : format_age(age) + " before this report");
}

std::string machine_link(const MachineStatus& m) {
  return "<a href=\"#" + anchor(m.machine.machine) + "\">" + report::html_escape(m.machine.machine) + "</a>";
}

// One row per kind EXPLAIN was latest run on: kind, when, what it found (largest first) or why not.
std::vector<std::vector<std::string>> explain_rows(const MachineStatus& m) {
  std::vector<std::vector<std::string>> rows;
  for (const auto& e : m.explains) {
    std::string found = found_text(e.summary);
    if (!e.summary.not_analysed.empty()) found += ": " + e.summary.not_analysed;
    rows.push_back({report::html_escape(e.kind), utc_minutes_html(e.produced_utc), report::html_escape(found)});
  }
  return rows;
}

// What the latest EXPLAIN of each machine and kind found, in a table of its own: a column of it beside
// the figures was squeezed to a word a line.
std::string explains_table(const std::vector<MachineStatus>& fleet) {
  std::vector<std::vector<std::string>> rows;
  for (const auto& m : fleet)
    for (auto& r : explain_rows(m)) {
      r.insert(r.begin(), machine_link(m));
      rows.push_back(std::move(r));
    }
  if (rows.empty()) return {};
  return report::html_table(report::Table(report::html_escape(explain_column_note) + ", largest first.",
                                          {"machine", "kind", "produced (UTC)", "found"}, std::move(rows), "text"));
}

std::string fleet_table(const std::vector<MachineStatus>& fleet, double report_s) {
  const auto columns = figure_columns(fleet);
  std::vector<std::string> header = {"machine", "state since (UTC)", "last DBB (UTC)"};
  for (const auto& c : columns) header.push_back(report::html_escape(c.header));
  std::vector<std::vector<std::string>> rows;
  for (const auto& m : fleet) {
    std::string state = m.machine.state.empty() ? "unknown" : m.machine.state;
    if (!m.machine.reason.empty()) state += " (" + m.machine.reason + ")";
    // The state and since when in one cell: a column less keeps the table within the page.
    std::vector<std::string> row = {
        machine_link(m),
        report::html_escape(state) + (m.machine.since.empty() ? "" : "<br>") + utc_minutes_html(m.machine.since),
        m.dbb_age_s ? when_made(report_s - *m.dbb_age_s, report_s) : "never"};
    for (const auto& c : columns) row.push_back(figure_cell(figure_of(m, c)));
    rows.push_back(std::move(row));
  }
  report::Table table("The latest result of each kind (value ± standard uncertainty u). * " +
                          report::html_escape(moved_rule_text) + ".",
                      std::move(header), std::move(rows));
  table.text_columns = {1, 2};  // state and times: words
  return report::html_table(table) + explains_table(fleet);
}

// One figure's trend: the values, and a bar from value − 2u to value + 2u at each (NaN-separated
// segments of one series).
std::string trend_plot(const std::string& kind, const Headline& first, const std::vector<double>& t_days,
                       const std::vector<Headline>& values, const std::string& time_axis) {
  report::LinePlot p;
  p.title = kind + ": " + first.label;
  p.x_label = "time / " + time_axis;
  p.y_label = first.label + " / " + first.unit;
  p.height = 240;
  report::Series v{"value", t_days, {}, report::palette(0), report::Style::line_markers, 1.2};
  report::Series bars{"±2u", {}, {}, report::palette(1), report::Style::line, 1.6};
  for (std::size_t i = 0; i < values.size(); ++i) {
    v.y.push_back(values[i].value);
    if (!values[i].u) continue;
    const double half = moved_coverage_factor * *values[i].u;
    bars.x.insert(bars.x.end(), {t_days[i], t_days[i], std::nan("")});
    bars.y.insert(bars.y.end(), {values[i].value - half, values[i].value + half, std::nan("")});
  }
  const auto [lo, hi] = std::minmax_element(t_days.begin(), t_days.end());
  // Room on both sides so that the first and last markers and bars are not cut by the axes; one unit
  // around a single result.
  const double margin = *hi - *lo < 1e-6 ? 0.5 : 0.05 * (*hi - *lo);
  p.x_range = report::Range{*lo - margin, *hi + margin};
  // The value axis spans the bars and at least a fifth of the largest value, centred on the data: a
  // change of 0.04 µm in a G of 17 µm is a flat line, not a fall from the top to the bottom of the plot.
  double y_lo = std::numeric_limits<double>::infinity(), y_hi = -y_lo, largest = 0.0;
  for (const auto* s : {&v.y, &bars.y})
    for (const double y : *s)
      if (std::isfinite(y)) {
        y_lo = std::min(y_lo, y);
        y_hi = std::max(y_hi, y);
        largest = std::max(largest, std::abs(y));
      }
  const double min_span = std::max(0.2 * largest, 1e-9);
  if (y_hi - y_lo < min_span) {
    const double mid = 0.5 * (y_lo + y_hi);
    p.y_range = report::Range{mid - 0.5 * min_span, mid + 0.5 * min_span};
  }
  const bool with_u = !bars.x.empty();
  p.series.push_back(std::move(v));
  if (with_u) p.series.push_back(std::move(bars));
  const std::string caption =
      report::html_escape(first.label + " (" + first.unit + ") of each " + kind + " result" +
                          (with_u ? ", with bars of ±2u (k = 2)" : ": the results give no uncertainty for it"));
  return report::html_figure(report::render(p), caption);
}

std::string machine_section(const MachineStatus& m, const std::vector<HistoryEntry>& entries) {
  std::string body;
  std::string state = m.machine.state.empty() ? "state unknown" : m.machine.state;
  if (!m.machine.since.empty()) state += " since " + m.machine.since;
  if (!m.machine.release.empty()) state += ", release " + m.machine.release;
  if (!m.machine.reason.empty()) state += " (" + m.machine.reason + ")";
  body += "<p>" + report::html_escape(state) + "; " + std::to_string(entries.size()) + " result(s).</p>";
  // Time axis: in days since the day of the machine's first result, or, when its results span less
  // than two days (two hours), in hours (minutes) since the hour (minute) of the first.
  double t0 = std::numeric_limits<double>::infinity();
  double t1 = -t0;
  for (const auto& e : entries)
    if (const auto t = parse_utc_iso(e.produced_utc)) {
      t0 = std::min(t0, *t);
      t1 = std::max(t1, *t);
    }
  if (!std::isfinite(t0)) return report::html_section("machine", anchor(m.machine.machine), m.machine.machine, body);
  const double span_s = t1 - t0;
  const double unit_s = span_s >= 2 * seconds_per_day ? seconds_per_day : span_s >= 7200.0 ? 3600.0 : 60.0;
  const char* unit = unit_s == seconds_per_day ? "days" : unit_s == 3600.0 ? "h" : "min";
  t0 = std::floor(t0 / unit_s) * unit_s;
  const std::string epoch =
      unit_s == seconds_per_day ? utc_iso_ms(t0).substr(0, 10) : utc_iso_ms(t0).substr(0, 16) + "Z";
  const std::string time_axis = std::string(unit) + " since " + epoch;
  // Per kind and figure (in table order): the times and values.
  struct Trend {
    std::string kind;
    std::vector<double> t;
    std::vector<Headline> values;
  };
  std::vector<Trend> trends;
  for (const auto& e : entries) {
    const auto t = parse_utc_iso(e.produced_utc);
    if (!t) continue;
    for (const auto& f : e.figures) {
      auto it = std::find_if(trends.begin(), trends.end(), [&](const Trend& tr) {
        return tr.kind == e.kind && tr.values.front().name == f.latest.name;
      });
      if (it == trends.end()) it = trends.insert(trends.end(), Trend{e.kind, {}, {}});
      it->t.push_back((*t - t0) / unit_s);
      it->values.push_back(f.latest);
    }
  }
  std::stable_sort(trends.begin(), trends.end(),
                   [](const Trend& a, const Trend& b) { return kind_rank(a.kind) < kind_rank(b.kind); });
  for (const auto& tr : trends) body += trend_plot(tr.kind, tr.values.front(), tr.t, tr.values, time_axis);
  if (!m.explains.empty())
    body += report::html_table(report::Table(report::html_escape(explain_column_note) + ", largest first.",
                                             {"kind", "produced (UTC)", "found"}, explain_rows(m), "text"));
  return report::html_section("machine", anchor(m.machine.machine), m.machine.machine, body);
}

}  // namespace

std::string render_fleet_report(const Store& store, const FleetReportOptions& options) {
  const auto fleet = fleet_status(store, options.now_s);
  std::vector<report::TocEntry> toc = {{"fleet", "Fleet"}};
  std::string body = report::html_section(
      "fleet", "fleet", "Fleet",
      fleet.empty() ? report::html_note("No machine has reported yet.") : fleet_table(fleet, options.now_s));
  for (const auto& m : fleet) {
    body += machine_section(m, history_of(store.results(m.machine.machine)));
    toc.push_back({anchor(m.machine.machine), m.machine.machine});
  }
  return report::html_document(options.title, options.subtitle, toc, body);
}

}  // namespace guideway::fleet
