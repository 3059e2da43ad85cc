#pragma once
// The fleet at a glance (`guideway fleet status`): per machine its state and since when, how old its
// last DBB result is, the headline figures of its latest result of each kind with a "moved" flag against
// the result before (headlines.hpp: k = 2) and what its latest EXPLAIN of each kind found.

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fleet/headlines.hpp"
#include "fleet/history.hpp"
#include "fleet/store.hpp"

namespace guideway::fleet {

struct KindStatus {
  std::string kind;
  std::string produced_utc;
  std::string session;
  std::vector<FigureChange> figures;
};

struct ExplainStatus {
  std::string kind;
  std::string produced_utc;
  results::Explanation summary;  // its residual curves are not kept
};

struct MachineStatus {
  MachineRow machine;
  std::optional<double> dbb_age_s;  // now - the latest DBB PARAMS's produced time
  std::vector<KindStatus> latest;   // one per kind, in kind_rank order
  std::vector<ExplainStatus> explains;
};

// Every machine of the store; `now_s`: seconds since the epoch (the ages count to it).
[[nodiscard]] std::vector<MachineStatus> fleet_status(const Store& store, double now_s);

[[nodiscard]] nlohmann::json status_json(const std::vector<MachineStatus>& fleet);
// One aligned line per machine, units in the headers; a figure that moved is marked '*' and the rule
// is printed under the table.
[[nodiscard]] std::string status_text(const std::vector<MachineStatus>& fleet);

// The EXPLAIN column of a machine: each kind's latest findings, largest first ("dbb: servo mismatch
// 2.53 µm, backlash 1.01 µm"), and what its header and the note under a table say of it.
inline constexpr const char* explain_column_header = "EXPLAIN (latest, largest first)";
inline constexpr const char* explain_column_note =
    "EXPLAIN: the effects its latest explanation of each kind found, with the size of each one's term (for DBB "
    "runs its range about the least-squares circle, as G's; else its peak-to-valley)";
[[nodiscard]] std::string explains_text(const MachineStatus& m);

// "45 s", "12 min", "5.2 h", "3.1 d".
[[nodiscard]] std::string format_age(double seconds);
// "45 s ago", or "in the future" for a negative age (a producer's clock ahead of this host's).
[[nodiscard]] std::string format_age_ago(double seconds);

// The figure columns of a fleet (kind and figure name, label and unit), in kind and table order.
struct FigureColumn {
  std::string kind;
  std::string name;
  std::string header;  // "G/µm"
};
[[nodiscard]] std::vector<FigureColumn> figure_columns(const std::vector<MachineStatus>& fleet);
// The messages `fleet serve` refused at ingest: how many, and the newest few (reason, topic, when);
// "" / a count of 0 when none.
inline constexpr std::size_t refusals_shown = 3;
[[nodiscard]] nlohmann::json refusals_json(const Store& store);
[[nodiscard]] std::string refusals_text(const Store& store);

// The machine's latest figure of a column, or null.
[[nodiscard]] const FigureChange* figure_of(const MachineStatus& m, const FigureColumn& c);

}  // namespace guideway::fleet
