#pragma once
// A machine's results over time, each with its headline figures and whether each moved against the
// result of the same kind before it (headlines.hpp: k = 2). What `guideway fleet history` prints and the
// fleet report plots.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/instrument.hpp"
#include "fleet/headlines.hpp"
#include "fleet/store.hpp"
#include "results/explanation.hpp"

namespace guideway::fleet {

struct FigureChange {
  Headline latest;
  std::optional<Headline> previous;  // the same figure in the previous result of the same kind
  bool moved = false;
};

struct HistoryEntry {
  std::string kind;
  std::string message_class;  // "PARAMS" or "EXPLAIN"
  std::string produced_utc;
  std::string received_utc;
  std::string session;
  std::vector<FigureChange> figures;      // PARAMS
  std::optional<results::Explanation> explain;  // EXPLAIN: what it found (its residual curves are not kept)
  bool readable = true;                   // false: its payload could not be read (no figures, no findings)
  // The instrument its header names (results/result_header.hpp; empty: none) and the date its
  // calibration was judged on then.
  std::string device;
  Instrument instrument;
  std::optional<CalendarDate> instrument_checked_on;
};

// Results in the order given (oldest first per kind), with each PARAMS figure compared to the previous
// PARAMS of its kind. A payload that cannot be read gives an entry marked unreadable, never an error.
[[nodiscard]] std::vector<HistoryEntry> history_of(const std::vector<ResultRow>& rows);

// Session kinds in the order people read them: dbb, runout, straightness, profile, then the others.
[[nodiscard]] int kind_rank(std::string_view kind);

[[nodiscard]] nlohmann::json to_json(const FigureChange& f);
[[nodiscard]] nlohmann::json history_json(std::string_view machine, const std::vector<HistoryEntry>& entries);
// One line per result: time, kind, session, its instrument (serial, calibration due; "EXPIRED at the
// session" when it had run out), then each figure "label value ± u unit" (moved: '*').
[[nodiscard]] std::string history_text(std::string_view machine, const std::vector<HistoryEntry>& entries);

// The rule, for outputs and docs.
inline constexpr const char* moved_rule_text =
    "moved: |latest - previous| > 2*sqrt(u_latest^2 + u_previous^2) (k = 2); figures without u are never flagged";

}  // namespace guideway::fleet
