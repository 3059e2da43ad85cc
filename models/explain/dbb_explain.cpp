// EXPLAIN for DBB runs (dbb_explain.hpp): Lai's guideway terms as the base, the runs' geometry for the effects.
#include "models/explain/dbb_explain.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <span>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "core/number_format.hpp"
#include "models/common/least_squares.hpp"
#include "models/dbb/arcs.hpp"
#include "models/dbb/geometry.hpp"
#include "models/dbb/identify.hpp"
#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"

namespace guideway::models::explain {

namespace {

constexpr double pi = std::numbers::pi;

using effects::Geo;

bool all_have_start_time(const std::vector<formats::DbbRun>& runs) {
  return std::all_of(runs.begin(), runs.end(),
                     [](const formats::DbbRun& r) { return r.metadata.count("start_time_s") > 0; });
}

double start_time_of(const formats::DbbRun& r) {
  const std::string& s = r.metadata.at("start_time_s");
  try {
    std::size_t used = 0;
    const double v = std::stod(s, &used);
    if (used != s.size() || !std::isfinite(v)) throw std::invalid_argument(s);
    return v;
  } catch (const std::exception&) {
    throw formats::DbbRunFormatError(r.source + ": start_time_s: not a number: '" + s + "'");
  }
}

std::vector<Geo> geometry(const std::vector<formats::DbbRun>& runs, bool machine_time) {
  // Time counts from the earliest run's start: a Unix-epoch clock (~1.8e9 s) would make a drift
  // column nearly constant and cost a sinusoid's phase its digits.
  double origin_s = 0.0;
  if (machine_time) {
    origin_s = start_time_of(runs.front());
    for (const auto& run : runs) origin_s = std::min(origin_s, start_time_of(run));
  }
  std::vector<Geo> g;
  std::size_t samples = 0;
  for (const auto& run : runs) samples += run.angle_rad.size();
  g.reserve(samples);  // grown by doubling, the copy and the old block would both be live: 1.5 x its size at peak
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const formats::DbbRun& run = runs[k];
    formats::validate_dbb_run(run);
    const double t0 = machine_time ? start_time_of(run) - origin_s : 0.0;
    for (std::size_t i = 0; i < run.angle_rad.size(); ++i) {
      Geo p;
      dbb::fill_sample_geometry(run, k, i, p);
      p.t_s = t0 + run.t_s[i];
      g.push_back(p);
    }
  }
  return g;
}

// Lai's geometric terms: the first 17 characteristic functions (backlash and servo mismatch are
// candidates here, not base), in um per reported unit.
constexpr double lai_si_per_reported[] = {1e-6, 1e-6, 1.0, 1.0, 1.0, 1e3, 1e6, 1e3, 1e6,
                                          1.0,  1e3,  1e6, 1e3, 1e6, 1.0, 1e3, 1e6};
constexpr std::size_t lai_geometric = std::size(lai_si_per_reported);

// Of the samples `rows` (nullptr: every sample), in that order.
Block lai_base(const std::vector<Geo>& g, const std::vector<Eigen::Index>* rows = nullptr) {
  Block b;
  const auto names = dbb::lai3_parameter_names();
  b.names.assign(names.begin(), names.begin() + lai_geometric);
  const auto n = static_cast<Eigen::Index>(rows ? rows->size() : g.size());
  b.columns.resize(n, static_cast<Eigen::Index>(lai_geometric));
  for (Eigen::Index r = 0; r < n; ++r) {
    const Geo& p = g[static_cast<std::size_t>(rows ? (*rows)[static_cast<std::size_t>(r)] : r)];
    const auto ch =
        dbb::lai3_characteristics(p.radius_m, p.height_m, static_cast<int>(p.dir), p.feed_m_per_s, p.zeta_rad);
    for (std::size_t k = 0; k < lai_geometric; ++k)
      b.columns(r, static_cast<Eigen::Index>(k)) = ch[k] * lai_si_per_reported[k] * 1e6;
  }
  return b;
}

std::vector<RunInfo> run_infos(const std::vector<formats::DbbRun>& runs) {
  std::vector<RunInfo> out;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const auto& r = runs[k];
    RunInfo ri;
    ri.label = "run" + std::to_string(k + 1) + " (" + (r.dir() > 0 ? "ccw" : "cw") + ")";
    ri.direction = r.dir();
    ri.feed_mm_per_min = std::round(r.feed_m_per_s * 60000.0 * 1e6) / 1e6;
    ri.geometry = printf_number("r%.6g", r.radius_m * 1e3) + printf_number("h%.6g", r.height_m * 1e3) + r.plane;
    out.push_back(ri);
  }
  return out;
}

void check_runs(const std::vector<formats::DbbRun>& runs) {
  if (runs.empty()) throw std::invalid_argument("explain: no runs");
  for (const auto& r : runs)
    if (r.plane != runs.front().plane)
      throw formats::DbbRunFormatError(r.source + ": plane " + r.plane + " differs from " + runs.front().source + " (" +
                                       runs.front().plane + ")");
}

// `reading_um`: the reading the model predicts per sample (the sensor's operating point; taking the
// measured value would let a candidate fit the very effects in it). `base`, `y_um`: the base refitted and
// what it explains, null for a given simulation.
Problem assemble_problem(const std::vector<formats::DbbRun>& runs, const std::shared_ptr<const std::vector<Geo>>& geo,
                         bool machine_time, const std::vector<double>& reading_um,
                         std::shared_ptr<const BasePredictions> base = nullptr) {
  const std::vector<Geo>& g = *geo;
  Problem p;
  p.model = "dbb";
  p.domain = "angle_deg";
  p.runs = run_infos(runs);
  // Locations: each run's time zero on the problem's axis (geometry()'s), and the machine clock's origin.
  if (machine_time) {
    double origin_s = start_time_of(runs.front());
    for (const auto& run : runs) origin_s = std::min(origin_s, start_time_of(run));
    p.clock_origin_s = origin_s;
    for (std::size_t k = 0; k < runs.size(); ++k) p.runs[k].start_s = start_time_of(runs[k]) - origin_s;
  }
  for (std::size_t k = 0; k < runs.size(); ++k) p.runs[k].source = runs[k].source;
  p.samples.reserve(g.size());
  for (const auto& q : g) {
    double deg = std::fmod(q.zeta_rad * 180 / pi, 360.0);
    if (deg < 0) deg += 360;
    p.samples.push_back({q.run, q.dL_um, deg, q.t_s});
  }
  const effects::DbbTerms terms{g,
                                geo,
                                runs,
                                machine_time,
                                reading_um,
                                effects::drive_tracks(g, dbb::drive_delays_s(runs)),
                                runs.front().plane,
                                std::move(base)};
  p.candidates = effects::dbb_candidates(terms);
  if (!machine_time && runs.size() > 1) {
    p.notes.push_back(
        "runs have no start_time_s metadata: a drift is fitted with its own offset per run, a vibration with its own "
        "phase");
    p.terms_per_run = true;
  }
  // A partial arc or a gap: what the runs hold of the axes' reversals, and that G is over the data arcs.
  for (auto& note : dbb::arc_notes(runs, runs.front().plane)) p.notes.push_back(std::move(note));
  bool ccw = false, cw = false;
  for (const auto& r : runs) (r.dir() > 0 ? ccw : cw) = true;
  if (!(ccw && cw))
    p.notes.push_back("one direction only: servo_mismatch has the signature of squareness and cannot be told apart");
  return p;
}

}  // namespace

Problem dbb_problem(const std::vector<formats::DbbRun>& runs) {
  check_runs(runs);
  const bool machine_time = all_have_start_time(runs);
  const auto geo = std::make_shared<const std::vector<Geo>>(geometry(runs, machine_time));
  const std::vector<Geo>& g = *geo;
  Block base = lai_base(g);
  Eigen::VectorXd y(static_cast<Eigen::Index>(g.size()));
  for (std::size_t i = 0; i < g.size(); ++i) y[static_cast<Eigen::Index>(i)] = g[i].dL_um;
  const LsqResult fit = solve_lsq(base.columns, y, Eigen::VectorXd(), base.names);
  if (!fit.ok) throw std::invalid_argument("explain: Lai base fit failed: " + fit.message);
  std::vector<double> reading(g.size());
  for (std::size_t i = 0; i < g.size(); ++i)
    reading[i] = y[static_cast<Eigen::Index>(i)] - fit.residual[static_cast<Eigen::Index>(i)];
  Problem p = assemble_problem(runs, geo, machine_time, reading,
                               std::make_shared<const BasePredictions>(
                                   [geo](const std::vector<Eigen::Index>* rows) { return lai_base(*geo, rows); }, y));
  // The yardstick of the contributions, as a ballbar's software ranks errors: the largest circular
  // deviation G of a run (ISO 230-4: the range of the reading about the run's least-squares circle), and
  // a finding's part of it the same range of its fitted term.
  p.deviation_name = "circular deviation G";
  auto spans = std::make_shared<std::vector<std::pair<std::size_t, std::vector<double>>>>();  // first sample, angles
  for (std::size_t i0 = 0; i0 < g.size();) {
    std::vector<double> zeta;
    std::size_t i1 = i0;
    for (; i1 < g.size() && g[i1].run == g[i0].run; ++i1) zeta.push_back(g[i1].zeta_rad);
    spans->emplace_back(i0, std::move(zeta));
    i0 = i1;
  }
  p.contribution_of = [spans](const Eigen::VectorXd& term_um) {
    double out = 0;
    for (const auto& [first, zeta] : *spans)
      out = std::max(out, dbb::range_about_circle(zeta, std::span<const double>(term_um.data() + first, zeta.size())));
    return out;
  };
  p.deviation_um = p.contribution_of(y);
  p.base = std::move(base);
  return p;
}

Problem dbb_compare_problem(const formats::DbbRun& simulated, const formats::DbbRun& measured) {
  if (simulated.angle_rad.size() != measured.angle_rad.size())
    throw std::invalid_argument("explain: " + simulated.source + " has " + std::to_string(simulated.angle_rad.size()) +
                                " samples, " + measured.source + " has " + std::to_string(measured.angle_rad.size()));
  for (std::size_t i = 0; i < simulated.angle_rad.size(); ++i)
    if (std::abs(simulated.angle_rad[i] - measured.angle_rad[i]) > 1e-6 * pi / 180)
      throw std::invalid_argument("explain: " + simulated.source + " and " + measured.source +
                                  " differ in angle at sample " + std::to_string(i + 1));
  formats::DbbRun diff = measured;
  for (std::size_t i = 0; i < diff.dL_m.size(); ++i) diff.dL_m[i] -= simulated.dL_m[i];
  const std::vector<formats::DbbRun> runs{diff};
  const bool machine_time = all_have_start_time(runs);
  const auto geo = std::make_shared<const std::vector<Geo>>(geometry(runs, machine_time));
  std::vector<double> reading(simulated.dL_m.size());
  for (std::size_t i = 0; i < reading.size(); ++i) reading[i] = simulated.dL_m[i] * 1e6;
  Problem p = assemble_problem(runs, geo, machine_time, reading);
  p.model = "dbb (simulated vs measured)";
  p.notes.push_back("no base refit: the residual is " + measured.source + " - " + simulated.source);
  return p;
}

Report explain_dbb_report(const std::vector<formats::DbbRun>& runs, const ExplainOptions& options) {
  return explain(dbb_problem(runs), options);
}

Report explain_dbb_difference(const formats::DbbRun& simulated, const formats::DbbRun& measured,
                              const ExplainOptions& options) {
  return explain(dbb_compare_problem(simulated, measured), options);
}

results::Explanation explain_dbb(const std::vector<formats::DbbRun>& runs, const ExplainOptions& options) {
  return explanation_of(explain_dbb_report(runs, options));
}

}  // namespace guideway::models::explain
