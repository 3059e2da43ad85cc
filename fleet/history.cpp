// A machine's results over time (history.hpp), each with its headline figures and what moved.
#include "fleet/history.hpp"

#include <cmath>
#include <map>

#include "core/number_format.hpp"
#include "core/printable.hpp"
#include "report/html.hpp"
#include "results/message_class.hpp"
#include "results/params.hpp"
#include "results/result_header.hpp"
#include "results/session_kinds.hpp"

namespace guideway::fleet {

int kind_rank(std::string_view kind) { return results::session_kind_rank(kind); }

namespace {

// "serial 1001, certificate C-17, due 2024-01-10 (EXPIRED at the session)"
std::string instrument_line(const HistoryEntry& e) {
  const Instrument& in = e.instrument;
  std::string out = printable(instrument_identity_text(in));
  if (in.calibration_due) {
    out += (out.empty() ? "" : ", ") + std::string("due ") + to_iso(*in.calibration_due);
    if (e.instrument_checked_on && calibration_expired(in, *e.instrument_checked_on))
      out += " (EXPIRED at the session, " + to_iso(*e.instrument_checked_on) + ")";
  }
  return out.empty() ? "(no serial or calibration stated)" : out;
}

}  // namespace

std::vector<HistoryEntry> history_of(const std::vector<ResultRow>& rows) {
  std::vector<HistoryEntry> out;
  std::map<std::string, std::vector<Headline>> previous;  // per kind: the figures of its last PARAMS
  for (const auto& r : rows) {
    HistoryEntry e{r.kind, r.message_class, r.produced_utc, r.received_utc, r.session, {}, {}, true, {}, {}, {}};
    // A row that cannot be read (stored before ingest checked shapes) is marked and skipped, never fatal.
    try {
      const nlohmann::json j = nlohmann::json::parse(r.payload);
      const results::ResultHeader header = results::read_header(j);
      e.device = header.device;
      e.instrument = header.instrument;
      e.instrument_checked_on = header.instrument_checked_on;
      if (r.message_class == results::to_string(results::MessageClass::explain)) {
        e.explain = results::explanation_from_json(j);
        e.explain->residuals.reset();  // what it found is read, not its curves: a history holds many
      } else {
        auto& before = previous[r.kind];
        auto figures = headlines(r.kind, results::params_from_json(j));
        for (auto& h : figures) {
          FigureChange c{h, std::nullopt, false};
          for (const auto& p : before)
            if (p.name == h.name) c.previous = p;
          c.moved = c.previous && moved(h, *c.previous);
          e.figures.push_back(std::move(c));
        }
        before = std::move(figures);
      }
    } catch (const std::exception&) {
      e = HistoryEntry{r.kind, r.message_class, r.produced_utc, r.received_utc, r.session, {}, {}, false, {}, {}, {}};
    }
    out.push_back(std::move(e));
  }
  return out;
}

nlohmann::json to_json(const FigureChange& f) {
  nlohmann::json j = {{"name", f.latest.name},
                      {"label", f.latest.label},
                      {"unit", f.latest.unit},
                      {"value", f.latest.value},
                      {"moved", f.moved}};
  if (f.latest.u) j["u"] = *f.latest.u;
  if (f.previous) {
    j["previous"] = f.previous->value;
    if (f.previous->u) j["previous_u"] = *f.previous->u;
  }
  return j;
}

nlohmann::json history_json(std::string_view machine, const std::vector<HistoryEntry>& entries) {
  nlohmann::json j = {{"machine", machine}, {"moved_rule", moved_rule_text}, {"results", nlohmann::json::array()}};
  for (const auto& e : entries) {
    nlohmann::json r = {{"kind", e.kind},
                        {"class", e.message_class},
                        {"produced_utc", e.produced_utc},
                        {"received_utc", e.received_utc},
                        {"session", e.session}};
    if (!e.readable) r["unreadable"] = true;
    if (!e.instrument.empty())
      r["instrument"] = results::instrument_json(e.device, e.instrument, e.instrument_checked_on.value_or(utc_today()));
    if (e.explain) {
      r["explain"] = results::found_json(*e.explain);
    } else {
      r["figures"] = nlohmann::json::array();
      for (const auto& f : e.figures) r["figures"].push_back(to_json(f));
    }
    j["results"].push_back(std::move(r));
  }
  return j;
}

std::string history_text(std::string_view machine, const std::vector<HistoryEntry>& entries) {
  // What came from a broker's message goes through printable(): no control character reaches the terminal.
  std::string out = printable(machine) + ": " + std::to_string(entries.size()) + " result(s), oldest first\n";
  for (const auto& e : entries) {
    out += printable(e.produced_utc) + "  " + printable(e.kind) + " " + e.message_class + "  " +
           (e.session.empty() ? "-" : printable(e.session)) + "\n";
    if (!e.readable) out += "    (its payload could not be read: skipped)\n";
    if (!e.instrument.empty()) out += "    instrument: " + instrument_line(e) + "\n";
    if (e.explain) out += "    found: " + printable(found_text(*e.explain)) + "\n";
    for (const auto& f : e.figures) {
      const std::string value = with_uncertainty(f.latest.value, f.latest.u.value_or(std::nan("")), 5);
      out += "    " + f.latest.label + ": " + value + " " + f.latest.unit + (f.moved ? "  *" : "") + "\n";
    }
  }
  if (!entries.empty()) out += "* " + std::string(moved_rule_text) + "\n";
  return out;
}

}  // namespace guideway::fleet
