#pragma once
// The fleet report: one self-contained HTML page (inline CSS and SVG, nothing fetched, no scripts) with
// the fleet table and, per machine, the trend of each headline figure over time with ±2u bars
// (report/html.hpp, report/svg.hpp; docs/plant.md).

#include <string>

#include "fleet/store.hpp"

namespace guideway::fleet {

struct FleetReportOptions {
  std::string title = "Guideway fleet";
  std::string subtitle;  // e.g. the generation time; empty: none (reproducible files)
  double now_s = 0.0;    // seconds since the epoch: the ages in the table count to it
};

[[nodiscard]] std::string render_fleet_report(const Store& store, const FleetReportOptions& options);

}  // namespace guideway::fleet
