// EXPLAIN's pass driver (explain.hpp): a pass over the whole problem, then passes with the places no effect
// explains set aside (engine/set_aside.hpp); and the helpers of the model front ends.
#include "models/explain/explain.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <tuple>

#include "core/number_format.hpp"
#include "models/common/amplitude_phase.hpp"
#include "models/common/least_squares.hpp"
#include "models/explain/engine/explain_pass.hpp"
#include "models/explain/engine/level_step.hpp"
#include "models/explain/engine/set_aside.hpp"
#include "models/explain/locate.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain {

namespace {

using engine::explain_once;
using engine::OffsetAfter;
using engine::Pass;
using engine::Reduced;

// The report of the last pass with the places set aside as the first of what remains, `unexplained`, and the
// first pass's baseline, noise and mismatch.
Report with_places_set_aside(const Problem& problem, const Report& first, Report out, std::vector<Location> aside,
                             const std::vector<bool>& keep) {
  const std::size_t n = problem.samples.size();
  out.n = first.n;
  out.set_aside = static_cast<std::size_t>(std::count(keep.begin(), keep.end(), false));
  out.noise_um = first.noise_um;
  out.mismatch = first.mismatch;
  aside = engine::merge_contiguous(std::move(aside), keep);
  Mismatch m;
  m.domain = problem.domain;
  m.band = "-";
  m.evidence =
      "no effect of the library explains it: set aside, the findings are fitted to the rest, with the reading free "
      "to stand off by a constant after each place in its run and, apart, in the runs after it (a nuisance for a "
      "step, not a finding)";
  for (const auto& l : aside) {
    m.where += (m.where.empty() ? "" : ", ") + l.run + " " + printf_number("%.4g", l.where.first) + ".." +
               printf_number("%.4g", l.where.second) + (problem.domain == "angle_deg" ? " deg" : " mm");
    m.ranges.emplace_back(std::min(l.where.first, l.where.second), std::max(l.where.first, l.where.second));
  }
  m.locations = aside;
  out.remaining.insert(out.remaining.begin(), std::move(m));
  engine::repeats_among(out.remaining, problem.domain);
  out.unexplained = true;
  out.notes.push_back(
      std::to_string(out.set_aside) + " of " + std::to_string(n) + " samples (" +
      printf_number("%.1f", 100.0 * static_cast<double>(out.set_aside) / static_cast<double>(n)) + " %) at " +
      std::to_string(aside.size()) +
      " places no effect explains were set aside; the baseline, findings and final fit are of the rest");
  return out;
}

// Whether explain() would set aside places of a pass's residual (in the samples of the pass's problem, `index` the
// whole problem's index of each) on top of `keep`: within max_set_aside of the samples, no run left too short.
engine::SetAsideCheck settable(const Problem& problem, const ExplainOptions& options, std::vector<Eigen::Index> index,
                               std::vector<bool> keep) {
  return [&problem, &options, index = std::move(index), keep = std::move(keep)](const std::vector<Location>& places) {
    std::vector<Location> whole = places;
    for (Location& l : whole) {
      l.first_sample = static_cast<std::size_t>(index[l.first_sample]);
      l.end_sample = static_cast<std::size_t>(index[l.end_sample - 1]) + 1;
    }
    std::vector<bool> trial = keep;
    const std::size_t count = engine::set_aside(problem, whole, trial);
    return !(static_cast<double>(count) > options.max_set_aside * static_cast<double>(keep.size())) &&
           engine::starved_run(problem, trial).empty();
  };
}

// A first pass that ends with findings and nothing structured left may have taken a step in a run's level with them
// (a ball slipping in its cup, seated again before the next run: a thermal drift, a servo lag and a lateral play took
// its level and its step, issue 41 item 10). The step (level_step.hpp) is their rival: the problem is explained again
// with the reading free to stand off from the step on, in its run and, apart, in the runs after (the offsets a place
// set aside leaves); when that fits better by the BIC, the step's sample counted as one value searched, the step's
// place is the first set aside. The strongest step beside the base first (where it could replace the first pass's
// own findings); where that does not win, the step beside the subset of the findings with which it fits best
// (winning_step: beside the base alone a backlash's reversal may stand above the slip 42 degrees before it). A first
// pass that ends `unexplained` may have left a place that is the start of such a step, which set aside with its
// offsets as located would take a real effect's own step with it (the probe's place from the slip to the backlash's
// reversal: the backlash fitted at 0.55 of 0.8 um, a thermal drift and a servo lag beside it): the step is sought
// beside the effects it held before its share rule dropped one, and taken only where the pass with it leaves nothing
// structured (the step explains the place and what follows it). Otherwise the first pass stands as it was.
std::vector<Location> step_to_set_aside(const Problem& problem, const ExplainOptions& options, const Pass& first) {
  const bool unexplained = first.report.unexplained;
  if (unexplained ? first.probe_terms.empty() : first.report.findings.empty()) return {};
  const std::vector<bool> all(problem.samples.size(), true);
  ExplainOptions quiet = options;
  quiet.on_progress = nullptr;
  const auto rival_wins = [&](const engine::LevelStep& step, bool screen) {
    const std::vector<OffsetAfter> after =
        engine::fitted_offsets(problem, all, std::vector<OffsetAfter>{OffsetAfter{step.run, step.at}});
    // The whole pass only where the step could replace the first pass's own findings (a search costs every generator
    // a call per fold again, and the problem with the step is a copy of it).
    if (screen && !engine::step_could_win(problem, after, first)) return false;
    const engine::Reduced with_step = engine::without_samples(problem, all, after);
    const Pass rival = explain_once(with_step.problem, quiet);
    if (unexplained && rival.report.unexplained) return false;
    const double searched = std::log(static_cast<double>(problem.samples.size()));
    return rival.report.final_fit.bic + searched < first.report.final_fit.bic;
  };
  std::optional<engine::LevelStep> strongest;
  if (!unexplained) {
    strongest = engine::level_step(problem, first.report.noise_um, options.alpha);
    if (!strongest) return {};
    if (rival_wins(*strongest, true)) return {strongest->place};
  }
  const std::optional<engine::WinningStep> step =
      engine::winning_step(problem, first.report.noise_um, options.alpha,
                           unexplained ? first.probe_terms : first.terms, first.report.final_fit.bic);
  if (!step || (strongest && strongest->at == step->step.at)) return {};
  // Beside a fault the step does not explain (a bump, a knock) the step and the held effects leave it structured:
  // no pass is run for that rival.
  if (unexplained) {
    const Located left = locate(problem, step->residual_um, options.alpha);
    if (left.structured && left.visible_energy > 0) return {};
  }
  if (!rival_wins(step->step, false)) return {};
  return {step->step.place};
}

}  // namespace

// When the residual left is structured at a few places no effect explains, the findings of the first
// pass may be partial fits of it or nothing at all (each real effect must remove most of the structure
// left without it, and the unexplained place is part of that structure). The places are set aside and the
// effects sought again in the rest: what is found there is reported with the places, `unexplained`.
Report explain(const Problem& problem, const ExplainOptions& options) {
  const std::size_t n = problem.samples.size();
  std::vector<Eigen::Index> index(n);
  for (std::size_t i = 0; i < n; ++i) index[i] = static_cast<Eigen::Index>(i);
  std::vector<bool> keep(n, true);
  constexpr int rounds = 3;
  Pass first =
      explain_once(problem, options, options.max_set_aside > 0 ? settable(problem, options, index, keep) : nullptr);
  // A step in a run's level that the first pass's findings took: set aside first.
  const std::vector<Location> step =
      options.max_set_aside > 0 ? step_to_set_aside(problem, options, first) : std::vector<Location>{};
  std::vector<Location> aside;
  std::vector<OffsetAfter> after;  // per place set aside: its run, the first sample after it
  engine::FittedOffsets fitted;    // of `after`, on the samples `keep` keeps
  std::optional<Pass> later;
  std::string starved;  // why the places were not set aside (a run would become too short to test)
  // Every place of a residual structured locally; of the probe (Pass::probe) only the strongest a round:
  // its other places may be the partial fits' leftovers, which the effects found without it explain.
  for (int round = 0; round < rounds && options.max_set_aside > 0; ++round) {
    const Pass& cur = later ? *later : first;
    const bool the_step = round == 0 && !step.empty();
    if (!the_step && !cur.report.unexplained) break;
    bool from_probe = false;
    std::vector<Location> places = the_step ? step : engine::remaining_places(cur, index, from_probe);
    if (places.empty()) break;
    if (from_probe)
      places = {*std::max_element(places.begin(), places.end(), [](const Location& a, const Location& b) {
        return std::abs(a.peak_um) < std::abs(b.peak_um);
      })};
    std::vector<bool> trial = keep;
    std::size_t count = engine::set_aside(problem, places, trial);
    // Places too wide to set aside (a step that stays for the rest of a run, seated again before the next, reads as
    // a plateau over the rest of the run) may stand out narrower in the probe's residual: its strongest place, as
    // where the residual is structured throughout (issue 41 item 10).
    if (static_cast<double>(count) > options.max_set_aside * static_cast<double>(n) && !from_probe) {
      places = engine::strongest_probe_place(cur, index);
      trial = keep;
      count = places.empty() ? n : engine::set_aside(problem, places, trial);
    }
    if (static_cast<double>(count) > options.max_set_aside * static_cast<double>(n)) break;
    if (const std::string run = engine::starved_run(problem, trial); !run.empty()) {
      starved = "the places no effect explains were not set aside: " + run + " would keep fewer than " +
                std::to_string(min_run_samples) + " samples, too few for the structure tests";
      break;
    }
    auto trial_after = after;
    for (const auto& l : places) trial_after.push_back(engine::offset_after(problem, l, trial));
    engine::FittedOffsets trial_fitted;
    trial_fitted.offsets = engine::fitted_offsets(problem, trial, trial_after, &trial_fitted.left_out);
    Reduced reduced = engine::without_samples(problem, trial, trial_fitted.offsets);
    if (options.on_progress)
      options.on_progress("pass " + std::to_string(round + 2) + ", " + std::to_string(aside.size() + places.size()) +
                          " places set aside");
    Pass next = explain_once(reduced.problem, options,
                             round + 1 < rounds ? settable(problem, options, reduced.kept, trial) : nullptr);
    keep = std::move(trial);
    after = std::move(trial_after);
    fitted = std::move(trial_fitted);
    index = std::move(reduced.kept);
    for (auto& l : places) l.set_aside = true;
    aside.insert(aside.end(), places.begin(), places.end());
    later = std::move(next);
  }
  if (!later) {
    if (!starved.empty()) first.report.notes.push_back(starved);
    return std::move(first.report);
  }
  engine::release_explained(problem, options, first.report.noise_um, aside, keep, after, fitted, *later);
  // The offsets the last pass did not fit, and why.
  later->report.notes.insert(later->report.notes.end(), fitted.left_out.begin(), fitted.left_out.end());
  return with_places_set_aside(problem, first.report, std::move(later->report), std::move(aside), keep);
}

Eigen::Index width(const Variant& v) {
  return v.fill ? static_cast<Eigen::Index>(v.block.names.size()) : v.block.columns.cols();
}

void write_columns(const Variant& v, Eigen::Ref<Eigen::MatrixXd> out) {
  if (v.fill)
    v.fill(out);
  else
    out = v.block.columns;
}

const Eigen::MatrixXd& columns_of(const Variant& v, Eigen::Index rows, Eigen::MatrixXd& scratch) {
  if (!v.fill) return v.block.columns;
  scratch.resize(rows, width(v));
  v.fill(scratch);
  return scratch;
}

std::vector<Eigen::Index> rows_in_use(const std::vector<bool>& use) {
  std::vector<Eigen::Index> rows;
  for (std::size_t i = 0; i < use.size(); ++i)
    if (use[i]) rows.push_back(static_cast<Eigen::Index>(i));
  return rows;
}

Eigen::VectorXd base_prediction(const Block& base, const Eigen::VectorXd& y_um, const std::vector<bool>& use) {
  const auto rows = rows_in_use(use);
  const LsqResult fit = solve_lsq(base.columns(rows, Eigen::all), y_um(rows), Eigen::VectorXd(), base.names);
  if (!fit.ok) return {};
  return base.columns * fit.fitted;
}

void absorb_station_means(const std::vector<std::size_t>& station_of, const std::vector<bool>* keep,
                          Eigen::Ref<Eigen::MatrixXd> x) {
  const auto n = x.rows();
  if (x.cols() == 0 || n == 0) return;
  if (static_cast<std::size_t>(n) != station_of.size() || (keep && keep->size() != station_of.size()))
    throw std::invalid_argument("explain: a station per row is needed to absorb the stations' means");
  const std::size_t stations = *std::max_element(station_of.begin(), station_of.end()) + 1;
  std::vector<double> count(stations, 0.0), sum(stations);
  for (std::size_t i = 0; i < station_of.size(); ++i)
    if (!keep || (*keep)[i]) count[station_of[i]] += 1;
  for (Eigen::Index c = 0; c < x.cols(); ++c) {
    auto col = x.col(c);
    const double before = col.squaredNorm();
    std::fill(sum.begin(), sum.end(), 0.0);
    for (Eigen::Index i = 0; i < n; ++i)
      if (!keep || (*keep)[static_cast<std::size_t>(i)]) sum[station_of[static_cast<std::size_t>(i)]] += col[i];
    for (Eigen::Index i = 0; i < n; ++i) {
      const std::size_t s = station_of[static_cast<std::size_t>(i)];
      col[i] = count[s] > 0 ? col[i] - sum[s] / count[s] : 0.0;
    }
    if (!(col.squaredNorm() > 1e-18 * before)) col.setZero();
  }
}

namespace {

void absorb_variant(Variant& v, const std::shared_ptr<const std::vector<std::size_t>>& stations) {
  for (Variant& b : v.beyond) absorb_variant(b, stations);
  if (v.fill) {
    v.fill = [fill = std::move(v.fill), stations](Eigen::Ref<Eigen::MatrixXd> out) {
      fill(out);
      absorb_station_means(*stations, nullptr, out);
    };
  } else {
    absorb_station_means(*stations, nullptr, v.block.columns);
  }
}

}  // namespace

void absorb_station_means(Problem& problem) {
  const std::size_t n = problem.samples.size();
  if (problem.station_of.size() != n)
    throw std::invalid_argument("explain: a station per sample is needed to absorb the stations' means");
  const auto stations = std::make_shared<const std::vector<std::size_t>>(problem.station_of);
  Eigen::MatrixXd y(static_cast<Eigen::Index>(n), 1);
  for (std::size_t i = 0; i < n; ++i) y(static_cast<Eigen::Index>(i), 0) = problem.samples[i].y_um;
  absorb_station_means(*stations, nullptr, y);
  for (std::size_t i = 0; i < n; ++i) problem.samples[i].y_um = y(static_cast<Eigen::Index>(i), 0);
  if (problem.base.columns.cols() > 0) absorb_station_means(*stations, nullptr, problem.base.columns);
  for (Candidate& c : problem.candidates) {
    for (Variant& v : c.variants) absorb_variant(v, stations);
    if (c.generate)
      c.generate = [generate = std::move(c.generate), stations](const Eigen::VectorXd& residual_um,
                                                                const std::vector<bool>& use) {
        std::vector<Variant> vs = generate(residual_um, use);
        for (Variant& v : vs) absorb_variant(v, stations);
        return vs;
      };
  }
  problem.station_means_absorbed = true;
}

Variant sensor_nonlinearity_variant(const std::vector<double>& reading_um) {
  double mean = 0;
  for (double v : reading_um) mean += v;
  mean /= static_cast<double>(reading_um.size());
  Variant v;
  v.block.names = {results::name(results::sensor_quadratic), results::name(results::sensor_cubic)};
  v.block.columns.resize(static_cast<Eigen::Index>(reading_um.size()), 2);
  for (std::size_t i = 0; i < reading_um.size(); ++i) {
    const double d = reading_um[i] - mean;
    v.block.columns(static_cast<Eigen::Index>(i), 0) = d * d;
    v.block.columns(static_cast<Eigen::Index>(i), 1) = d * d * d;
  }
  return v;
}

Eigen::VectorXd BasePredictions::predict(const std::vector<bool>& use) const {
  if (held_) return base_prediction(*held_, y_, use);
  // base_prediction's steps, on the same numbers.
  const auto rows = rows_in_use(use);
  Eigen::VectorXd fitted;
  {
    const Block in_use = make_(&rows);
    const LsqResult fit = solve_lsq(in_use.columns, y_(rows), Eigen::VectorXd(), in_use.names);
    if (!fit.ok) return {};
    fitted = fit.fitted;
  }
  return make_(nullptr).columns * fitted;
}

std::shared_ptr<const Eigen::VectorXd> BasePredictions::of(const std::vector<bool>& use) const {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [mask, predicted] : recent_)
      if (mask == use) return predicted;
  }
  auto predicted = std::make_shared<const Eigen::VectorXd>(predict(use));
  const std::lock_guard<std::mutex> lock(mutex_);
  if (recent_.size() >= kept) recent_.erase(recent_.begin());
  recent_.emplace_back(use, predicted);
  return predicted;
}

std::function<std::vector<Variant>(const Eigen::VectorXd&, const std::vector<bool>&)> sensor_nonlinearity_generator(
    const Block& base, const Eigen::VectorXd& y_um, std::vector<double> offset_um) {
  if (static_cast<std::size_t>(base.columns.rows()) != static_cast<std::size_t>(y_um.size()))
    throw std::invalid_argument("explain: sensor_nonlinearity: base, samples and offsets differ in length");
  return sensor_nonlinearity_generator(std::make_shared<const BasePredictions>(base, y_um), std::move(offset_um));
}

std::function<std::vector<Variant>(const Eigen::VectorXd&, const std::vector<bool>&)> sensor_nonlinearity_generator(
    std::shared_ptr<const BasePredictions> base, std::vector<double> offset_um) {
  if (!offset_um.empty() && offset_um.size() != static_cast<std::size_t>(base->rows()))
    throw std::invalid_argument("explain: sensor_nonlinearity: base, samples and offsets differ in length");
  return [base, offset = std::move(offset_um)](const Eigen::VectorXd&, const std::vector<bool>& use) {
    const Eigen::VectorXd& y = base->y();
    if (use.size() != static_cast<std::size_t>(base->rows()))
      throw std::invalid_argument("explain: sensor_nonlinearity: the row mask and the samples differ in length");
    const auto shared = base->of(use);
    const Eigen::VectorXd& predicted = *shared;
    if (predicted.size() == 0) return std::vector<Variant>{};
    std::vector<double> reading(use.size());
    for (std::size_t i = 0; i < reading.size(); ++i) {
      const auto r = static_cast<Eigen::Index>(i);
      reading[i] = (use[i] ? y[r] - (y[r] - predicted[r]) : predicted[r]) + (offset.empty() ? 0.0 : offset[i]);
    }
    return std::vector<Variant>{sensor_nonlinearity_variant(reading)};
  };
}

std::vector<ParamValue> amp_phase(const std::string& amp_name, const std::string& phase_name, const Eigen::VectorXd& x,
                                  const Eigen::MatrixXd& cov) {
  const AmplitudePhase ap = amplitude_phase(x[0], x[1], cov(0, 0), cov(1, 1), cov(0, 1));
  constexpr double deg = 180 / std::numbers::pi;
  return {{amp_name, ap.amplitude, ap.u_amplitude}, {phase_name, ap.phase_rad * deg, ap.u_phase_rad * deg}};
}

}  // namespace guideway::models::explain
