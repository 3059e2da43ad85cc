// The fleet at a glance (fleet_status.hpp): per machine its state, its latest results and their headline figures.
#include "fleet/fleet_status.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "core/number_format.hpp"
#include "core/printable.hpp"
#include "core/utc_time.hpp"
#include "results/message_class.hpp"
#include "results/session_kinds.hpp"

namespace guideway::fleet {

namespace {

// Columns by what a terminal shows: UTF-8 continuation bytes take no column ("µm").
std::size_t display_width(const std::string& s) {
  return static_cast<std::size_t>(
      std::count_if(s.begin(), s.end(), [](char c) { return (static_cast<unsigned char>(c) & 0xC0) != 0x80; }));
}

std::string pad(const std::string& s, std::size_t width, bool right) {
  const std::string fill(width > display_width(s) ? width - display_width(s) : 0, ' ');
  return right ? fill + s : s + fill;
}

}  // namespace

std::vector<MachineStatus> fleet_status(const Store& store, double now_s) {
  std::map<std::string, MachineStatus> by_name;
  for (auto& m : store.machines()) by_name[m.machine].machine = m;
  // The two newest results of each machine, class and kind: the latest and the one it is compared to.
  const auto rows = store.latest_results(2);
  for (std::size_t i = 0; i < rows.size();) {
    std::size_t end = i;
    while (end < rows.size() && rows[end].machine == rows[i].machine &&
           rows[end].message_class == rows[i].message_class && rows[end].kind == rows[i].kind)
      ++end;
    const std::vector<ResultRow> group(rows.begin() + static_cast<std::ptrdiff_t>(i),
                                       rows.begin() + static_cast<std::ptrdiff_t>(end));
    auto entries = history_of(group);
    auto& m = by_name[rows[i].machine];
    if (m.machine.machine.empty()) m.machine.machine = rows[i].machine;
    auto& last = entries.back();
    if (last.message_class == results::to_string(results::MessageClass::explain)) {
      if (last.explain) m.explains.push_back({last.kind, last.produced_utc, *last.explain});
    } else {
      m.latest.push_back({last.kind, last.produced_utc, last.session, std::move(last.figures)});
      if (last.kind == results::dbb_kind.name)
        if (const auto t = parse_utc_iso(last.produced_utc)) m.dbb_age_s = now_s - *t;
    }
    i = end;
  }
  std::vector<MachineStatus> out;
  for (auto& [name, m] : by_name) {
    const auto by_kind = [](const auto& a, const auto& b) {
      return std::pair(kind_rank(a.kind), a.kind) < std::pair(kind_rank(b.kind), b.kind);
    };
    std::sort(m.latest.begin(), m.latest.end(), by_kind);
    std::sort(m.explains.begin(), m.explains.end(), by_kind);
    out.push_back(std::move(m));
  }
  return out;
}

std::vector<FigureColumn> figure_columns(const std::vector<MachineStatus>& fleet) {
  std::vector<std::pair<std::pair<int, std::string>, std::vector<FigureColumn>>> kinds;  // in first-seen table order
  for (const auto& m : fleet) {
    for (const auto& k : m.latest) {
      auto it = std::find_if(kinds.begin(), kinds.end(), [&](const auto& e) { return e.first.second == k.kind; });
      if (it == kinds.end()) it = kinds.insert(kinds.end(), {{kind_rank(k.kind), k.kind}, {}});
      for (const auto& f : k.figures) {
        auto& cols = it->second;
        if (std::none_of(cols.begin(), cols.end(), [&](const FigureColumn& c) { return c.name == f.latest.name; }))
          cols.push_back({k.kind, f.latest.name, f.latest.label + "/" + f.latest.unit});
      }
    }
  }
  std::stable_sort(kinds.begin(), kinds.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<FigureColumn> out;
  for (auto& k : kinds) out.insert(out.end(), k.second.begin(), k.second.end());
  return out;
}

const FigureChange* figure_of(const MachineStatus& m, const FigureColumn& c) {
  for (const auto& k : m.latest)
    if (k.kind == c.kind)
      for (const auto& f : k.figures)
        if (f.latest.name == c.name) return &f;
  return nullptr;
}

std::string format_age_ago(double seconds) {
  if (!std::isfinite(seconds)) return "-";
  if (seconds < 0) return "in the future";  // a producer's clock ahead of this host's
  return format_age(seconds) + " ago";
}

std::string format_age(double seconds) {
  if (!std::isfinite(seconds)) return "-";
  if (seconds < 0) return "in the future";
  if (seconds < 120) return printf_number("%.0f s", seconds);
  if (seconds < 7200) return printf_number("%.0f min", seconds / 60);
  if (seconds < 2 * 86400) return printf_number("%.1f h", seconds / 3600);
  return printf_number("%.1f d", seconds / 86400);
}

nlohmann::json status_json(const std::vector<MachineStatus>& fleet) {
  nlohmann::json j = {{"moved_rule", moved_rule_text}, {"machines", nlohmann::json::array()}};
  for (const auto& m : fleet) {
    nlohmann::json o = {{"machine", m.machine.machine},
                        {"state", m.machine.state},
                        {"since", m.machine.since},
                        {"release", m.machine.release},
                        {"reason", m.machine.reason},
                        {"last_seen_utc", m.machine.last_seen_utc},
                        {"dbb_age_s", m.dbb_age_s ? nlohmann::json(*m.dbb_age_s) : nlohmann::json()},
                        {"latest", nlohmann::json::object()},
                        {"explain", nlohmann::json::object()}};
    for (const auto& k : m.latest) {
      auto& r = o["latest"][k.kind] = {
          {"produced_utc", k.produced_utc}, {"session", k.session}, {"figures", nlohmann::json::array()}};
      for (const auto& f : k.figures) r["figures"].push_back(to_json(f));
    }
    for (const auto& e : m.explains) {
      auto r = results::found_json(e.summary);
      r["produced_utc"] = e.produced_utc;
      o["explain"][e.kind] = std::move(r);
    }
    j["machines"].push_back(std::move(o));
  }
  return j;
}

std::string explains_text(const MachineStatus& m) {
  std::string found;
  for (const auto& e : m.explains) found += (found.empty() ? "" : "; ") + e.kind + ": " + found_text(e.summary);
  return found;
}

std::string status_text(const std::vector<MachineStatus>& fleet) {
  if (fleet.empty()) return "no machines yet\n";
  const auto columns = figure_columns(fleet);
  std::vector<std::string> header = {"MACHINE", "STATE", "SINCE (UTC)", "LAST DBB"};
  for (const auto& c : columns) header.push_back(c.header + " ");  // the cells end in the moved mark or a space
  header.emplace_back(explain_column_header);
  std::vector<std::vector<std::string>> rows;
  bool any_moved = false;
  for (const auto& m : fleet) {
    std::string state = m.machine.state.empty() ? "?" : m.machine.state;
    if (m.machine.state == "offline" && !m.machine.reason.empty()) state += " (" + m.machine.reason + ")";
    std::vector<std::string> row = {m.machine.machine, state,
                                    m.machine.since.empty() ? "-" : m.machine.since.substr(0, 19),
                                    m.dbb_age_s ? format_age_ago(*m.dbb_age_s) : "never"};
    for (const auto& c : columns) {
      const auto* f = figure_of(m, c);
      row.push_back(f ? significant_digits(f->latest.value, 3) + (f->moved ? "*" : " ") : "- ");
      any_moved = any_moved || (f && f->moved);
    }
    const std::string found = explains_text(m);
    row.push_back(found.empty() ? "-" : found);
    rows.push_back(std::move(row));
  }
  std::vector<std::size_t> width(header.size());
  for (std::size_t c = 0; c < header.size(); ++c) {
    width[c] = display_width(header[c]);
    for (const auto& r : rows) width[c] = std::max(width[c], display_width(r[c]));
  }
  // Every cell comes from a broker's message: no control character of it reaches the terminal.
  for (auto& r : rows)
    for (auto& cell : r) cell = printable(cell);
  const auto line = [&](const std::vector<std::string>& cells) {
    std::string s;
    for (std::size_t c = 0; c < cells.size(); ++c) {
      const bool number = c >= 4 && c + 1 < cells.size();  // figure columns: right-aligned
      if (c) s += "  ";
      s += c + 1 == cells.size() ? cells[c] : pad(cells[c], width[c], number);
    }
    return s + "\n";
  };
  std::string out = line(header);
  for (const auto& r : rows) out += line(r);
  out += "* " + std::string(moved_rule_text) + (any_moved ? "\n" : " (none moved)\n");
  if (std::any_of(fleet.begin(), fleet.end(), [](const MachineStatus& m) { return !m.explains.empty(); }))
    out += std::string(explain_column_note) + "\n";
  return out;
}

nlohmann::json refusals_json(const Store& store) {
  nlohmann::json j = {{"count", store.refused_count()}, {"newest", nlohmann::json::array()}};
  for (const auto& r : store.refusals(refusals_shown))
    j["newest"].push_back({{"machine", r.machine},
                           {"topic", r.topic},
                           {"reason", r.reason},
                           {"received_utc", r.received_utc},
                           {"size_bytes", r.size_bytes}});
  return j;
}

std::string refusals_text(const Store& store) {
  const auto count = store.refused_count();
  if (count == 0) return {};
  std::string out =
      "refused at ingest: " + std::to_string(count) + " message(s) (malformed: never stored); the newest:\n";
  for (const auto& r : store.refusals(refusals_shown))
    out +=
        "  " + printable(r.received_utc.substr(0, 19)) + "  " + printable(r.topic) + "  " + printable(r.reason) + "\n";
  return out;
}

}  // namespace guideway::fleet
