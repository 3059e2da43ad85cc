#include "models/dbb/json.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace guideway::models::dbb {

namespace {

nlohmann::json value_json(const Estimate& e) {
  nlohmann::json j = {{"value", e.value}};
  if (e.fitted && std::isfinite(e.u)) j["u"] = e.u;
  return j;
}

nlohmann::json fit_json(const FitSummary& f) {
  nlohmann::json j = {{"rms_um", f.rms_um}, {"n", f.n}, {"unidentifiable", f.unidentifiable}};
  if (std::isfinite(f.condition_number))
    j["condition_number"] = f.condition_number;
  else
    j["condition_number"] = "inf";
  if (!f.combinations.empty()) {
    auto& c = j["combinations"] = nlohmann::json::array();
    for (const auto& k : f.combinations) c.push_back({{"expression", k.expression}, {"value", k.value}, {"u", k.u}});
  }
  if (!f.message.empty()) j["message"] = f.message;
  return j;
}

void table(std::ostringstream& o, const std::vector<Estimate>& list) {
  for (const auto& e : list) {
    o << "  " << std::left << std::setw(30) << e.name << std::right << std::setw(14) << std::setprecision(6) << e.value;
    if (e.fitted && std::isfinite(e.u)) o << "  +/- " << std::setprecision(3) << e.u;
    o << "\n";
  }
}

}  // namespace

nlohmann::json to_json(const Identification& id) {
  nlohmann::json j;
  j["model"] = id.model;
  j["plane"] = id.plane;
  j["runs"] = nlohmann::json::array();
  for (const auto& r : id.runs) {
    j["runs"].push_back({{"source", r.source},
                         {"radius_mm", r.radius_mm},
                         {"height_mm", r.height_mm},
                         {"direction", r.direction},
                         {"feed_mm_per_min", r.feed_mm_per_min},
                         {"n", r.n},
                         {"circular_deviation_um", r.circular_deviation_um},
                         {"residual_rms_um", r.residual_rms_um}});
  }
  j["diagnostics"] = nlohmann::json::object();
  for (const auto& e : id.diagnostics) j["diagnostics"][e.name] = value_json(e);
  j["lai3"] = nlohmann::json::object();
  for (const auto& e : id.lai3) j["lai3"][e.name] = value_json(e);
  if (!id.beside.empty()) {  // only when terms were fitted beside (compensation's identification)
    j["beside"] = nlohmann::json::object();
    for (const auto& e : id.beside) j["beside"][e.name] = value_json(e);
  }
  j["ranking"] = nlohmann::json::array();
  for (const auto& c : id.ranking)
    j["ranking"].push_back(
        {{"name", c.name},
         {"contribution_um", c.contribution_um},
         {"percent_of_circular_deviation", std::isfinite(c.percent) ? nlohmann::json(c.percent) : nlohmann::json()}});
  j["ranking_model"] = id.ranking_model;
  j["notes"] = id.notes;
  j["fit"] = fit_json(id.fit);
  j["diagnostics_fit"] = fit_json(id.diagnostics_fit);
  return j;
}

std::string to_text(const Identification& id) {
  std::ostringstream o;
  o << "DBB identification (" << id.model << "), " << id.runs.size() << " run(s)\n";
  for (const auto& r : id.runs) {
    o << "  " << r.source << ": r " << r.radius_mm << " mm, h " << r.height_mm << " mm, " << r.direction << ", "
      << r.feed_mm_per_min << " mm/min, " << r.n << " points, G " << std::setprecision(4) << r.circular_deviation_um
      << " um, residual " << r.residual_rms_um << " um rms\n";
  }
  o << "\nBallbar diagnostics (value +/- standard uncertainty)\n";
  table(o, id.diagnostics);
  o << "  fit: rms " << std::setprecision(4) << id.diagnostics_fit.rms_um << " um, n " << id.diagnostics_fit.n
    << ", condition " << std::setprecision(3) << id.diagnostics_fit.condition_number << "\n";
  if (!id.diagnostics_fit.unidentifiable.empty()) o << "  refused: " << id.diagnostics_fit.message << "\n";
  if (!id.ranking.empty()) {
    o << "\nWhat to fix first (each error's part of the circular deviation G, from the " << id.ranking_model << ")\n";
    for (const auto& c : id.ranking)
      o << "  " << std::left << std::setw(30) << c.name << std::right << std::setw(10) << std::setprecision(3)
        << c.contribution_um << " um  " << std::setw(6) << std::setprecision(3) << c.percent << " % of G\n";
  }
  for (const auto& n : id.notes) o << "note: " << n << "\n";
  o << "\nLai third-order model\n";
  table(o, id.lai3);
  o << "  fit: rms " << std::setprecision(4) << id.fit.rms_um << " um, n " << id.fit.n << ", condition "
    << std::setprecision(3) << id.fit.condition_number << "\n";
  if (!id.fit.unidentifiable.empty()) {
    o << "  refused: " << id.fit.message << "\n";
    for (const auto& c : id.fit.combinations)
      o << "    determined instead: " << c.expression << " = " << std::setprecision(6) << c.value << " +/- "
        << std::setprecision(3) << c.u << "\n";
  }
  return o.str();
}

}  // namespace guideway::models::dbb
