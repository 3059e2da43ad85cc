// One pass of EXPLAIN over a problem (explain_pass.hpp).
#include "models/explain/engine/explain_pass.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "models/common/least_squares.hpp"
#include "models/explain/engine/effect_selection.hpp"
#include "models/explain/engine/folds.hpp"
#include "models/explain/engine/selection.hpp"
#include "models/explain/engine/term_tests.hpp"
#include "models/explain/locate.hpp"

namespace guideway::models::explain::engine {

namespace {

// Residual curves on the first run's grid (sorted, decimated); other runs interpolated onto it. One step
// per entry of `steps` (the base model, then after each finding).
void add_curves(Report& rep, const Problem& problem, const std::vector<std::pair<std::string, Eigen::VectorXd>>& steps,
                std::size_t max_points) {
  if (max_points == 0 || steps.empty()) return;
  const auto ranges = run_ranges(problem);
  const auto sorted_run = [&](std::size_t k, const Eigen::VectorXd& r) {
    std::vector<std::pair<double, double>> xy;
    for (std::size_t i = ranges[k].first; i < ranges[k].second; ++i) {
      double w = problem.samples[i].where;
      if (problem.domain == "angle_deg") w = std::fmod(std::fmod(w, 360.0) + 360.0, 360.0);
      xy.emplace_back(w, r[static_cast<Eigen::Index>(i)]);
    }
    std::sort(xy.begin(), xy.end());
    return xy;
  };
  const auto at = [](const std::vector<std::pair<double, double>>& xy, double x) {
    auto it = std::lower_bound(xy.begin(), xy.end(), std::make_pair(x, -1e300));
    if (it == xy.begin()) return xy.front().second;
    if (it == xy.end()) return xy.back().second;
    const auto& hi = *it;
    const auto& lo = *(it - 1);
    return hi.first == lo.first ? hi.second
                                : lo.second + (hi.second - lo.second) * (x - lo.first) / (hi.first - lo.first);
  };
  const auto grid_src = sorted_run(0, steps.front().second);
  if (grid_src.empty()) return;
  const std::size_t stride = (grid_src.size() + max_points - 1) / max_points;
  for (std::size_t i = 0; i < grid_src.size(); i += stride) rep.curve_x.push_back(grid_src[i].first);
  rep.curve_domain = problem.domain;
  for (std::size_t k = 0; k < ranges.size(); ++k)
    if (ranges[k].second > ranges[k].first) rep.curve_runs.push_back(problem.runs[k].label);
  for (const auto& [label, residual] : steps) {
    ResidualStep step{label, {}};
    for (std::size_t k = 0; k < ranges.size(); ++k) {
      if (ranges[k].second == ranges[k].first) continue;
      const auto xy = sorted_run(k, residual);
      std::vector<double> v;
      v.reserve(rep.curve_x.size());
      for (double x : rep.curve_x) v.push_back(at(xy, x));
      step.residual_um.push_back(std::move(v));
    }
    rep.curve_steps.push_back(std::move(step));
  }
}

// A finding's fitted term's size: as the model measures it, else its peak-to-valley over each run.
void set_contribution(const Problem& problem, const std::vector<std::pair<std::size_t, std::size_t>>& ranges,
                      const Eigen::VectorXd& term, Finding& fd) {
  if (problem.contribution_of) {
    fd.contribution_um = problem.contribution_of(term);
  } else {
    for (const auto& [a, b] : ranges) {
      if (b <= a) continue;
      const auto seg = term.segment(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b - a));
      fd.contribution_um = std::max(fd.contribution_um, seg.maxCoeff() - seg.minCoeff());
    }
  }
  if (problem.deviation_um > 0) fd.contribution_percent = 100 * fd.contribution_um / problem.deviation_um;
}

// The findings in the order taken: parameters from the final joint fit; the BIC, p-value and share of each
// against the final model without it; RMS and held-out RMS after each in turn. `steps` gets the residual
// after each.
void add_findings(const Problem& problem, const Selection& sel, const EffectSelection& chosen, double sigma,
                  double visible_floor, bool keep_columns, Report& rep,
                  std::vector<std::pair<std::string, Eigen::VectorXd>>& steps) {
  const std::vector<Term>& terms = chosen.terms();
  const std::size_t n = problem.samples.size();
  const auto ranges = run_ranges(problem);
  const LsqResult final_fit = sel.fit(terms);
  if (!final_fit.ok) throw std::invalid_argument("explain: least squares failed: " + final_fit.message);
  Eigen::Index offset = problem.base.columns.cols();
  for (std::size_t k = 0; k < terms.size(); ++k) {
    const Candidate& cand = problem.candidates[terms[k].cand];
    const Variant& v = variant_of(problem, terms[k]);
    const std::vector<Term> prefix(terms.begin(), terms.begin() + static_cast<std::ptrdiff_t>(k + 1));
    const Model pm = sel.model(prefix);
    const DropTest d = significance(sel, terms, k, chosen.model());
    Finding fd;
    fd.effect = cand.effect;
    fd.parameters = widened(sel, terms, k, chosen.model(), params_of(v, final_fit, offset));
    fd.delta_bic = d.delta_bic;
    fd.p_value = d.p;
    fd.rms_um_after = std::sqrt(pm.rss / static_cast<double>(n));
    fd.heldout_rms_um_after = k + 1 == terms.size() ? chosen.heldout() : sel.heldout(prefix, none).rms;
    fd.share = share(sel, terms, k, chosen.model(), sigma, visible_floor);
    Eigen::MatrixXd scratch;
    const Eigen::MatrixXd& columns = columns_of(v, static_cast<Eigen::Index>(n), scratch);
    set_contribution(problem, ranges, columns * final_fit.x.segment(offset, columns.cols()), fd);
    fd.why = cand.why;
    if (keep_columns) {
      // Over every sample of the runs, also when some were set aside: the shape is the effect's wherever
      // it was fitted (a model that fits it beside its own terms needs every sample's value).
      const Eigen::MatrixXd all = v.all_samples ? v.all_samples() : columns;
      fd.column_names = v.block.names;
      for (Eigen::Index c = 0; c < all.cols(); ++c)
        fd.columns_um.emplace_back(all.col(c).data(), all.col(c).data() + all.rows());
    }
    rep.findings.push_back(std::move(fd));
    steps.emplace_back("+ " + cand.effect, pm.residual);
    offset += columns.cols();
  }
}

// The verdict on what is left: `unexplained`, with its places, when the residual is structured and some of
// it stands above the noise (a place, or "throughout"). A residual significant only as a whole -- not white,
// or a band's energy raised, with no coefficient above the universal threshold -- has no place a user could
// look at and nothing an effect could be tested on beyond the noise: it is not `unexplained` but a note
// (docs/explain.md step 5). Before, it was `unexplained` "below the noise everywhere", which a borderline
// whiteness test turned on and off between live runs of the same machine.
void settle_verdict(const Located& fin, Report& rep) {
  if (!fin.structured || fin.visible_energy > 0) {
    rep.remaining = fin.places;
    rep.unexplained = fin.structured;
    return;
  }
  rep.unexplained = false;
  const std::string evidence = fin.places.empty() ? std::string() : " (" + fin.places.front().evidence + ")";
  rep.notes.push_back(
      "the residual left is not white noise" + evidence +
      ", but no part of it stands above the noise: correlated noise at the noise level, with no place to look at "
      "and nothing an effect could be tested on; not reported as unexplained");
}

}  // namespace

std::vector<const Eigen::MatrixXd*> columns_of_terms(const Problem& problem, const std::vector<TermColumns>& terms,
                                                     Eigen::Index n, std::vector<Eigen::MatrixXd>& scratch) {
  scratch.resize(terms.size());
  std::vector<const Eigen::MatrixXd*> columns;
  for (std::size_t j = 0; j < terms.size(); ++j) {
    const TermColumns& t = terms[j];
    columns.push_back(t.generated ? &t.all_samples
                                  : &columns_of(problem.candidates[t.cand].variants[t.index], n, scratch[j]));
    if (columns.back()->rows() != n) return {};
  }
  return columns;
}

Eigen::VectorXd observations(const Problem& problem) {
  const std::size_t n = problem.samples.size();
  if (n < 32) throw std::invalid_argument("explain: too few samples (" + std::to_string(n) + ", need 32)");
  if (problem.base.columns.cols() > 0 && static_cast<std::size_t>(problem.base.columns.rows()) != n)
    throw std::invalid_argument("explain: base design has the wrong number of rows");
  Eigen::VectorXd y(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    y[static_cast<Eigen::Index>(i)] = problem.samples[i].y_um;
    if (!std::isfinite(problem.samples[i].y_um)) throw std::invalid_argument("explain: non-finite sample");
  }
  for (const auto& c : problem.candidates)
    for (const auto& v : c.variants)
      if (!v.fill && static_cast<std::size_t>(v.block.columns.rows()) != n)
        throw std::invalid_argument("explain: candidate " + c.effect + " has the wrong number of rows");
  return y;
}

Pass explain_once(const Problem& problem, const ExplainOptions& options, const SetAsideCheck& can_set_aside) {
  const Eigen::VectorXd y = observations(problem);
  const std::size_t n = problem.samples.size();
  const auto ranges = run_ranges(problem);
  Report rep;
  rep.model = problem.model;
  rep.n = n;
  rep.notes = problem.notes;
  const HeldOutScheme scheme = heldout_scheme(problem, options, ranges);
  rep.heldout_scheme = scheme.name;

  const Selection sel(problem, options, y, scheme);
  const Model base = sel.model({});
  const HeldOut base_ho = sel.heldout({}, none);
  // Every effect will be refused for it: say why once, whether or not a candidate gets that far.
  if (!base_ho.failure.empty())
    rep.notes.push_back("held-out RMS of the base not computable (" + base_ho.failure + ")");
  rep.baseline = {std::sqrt(base.rss / static_cast<double>(n)), base.bic, base_ho.rms, base.rank + base.searched};
  const Located base_loc = locate(problem, base.residual, options.alpha);
  rep.noise_um = base_loc.sigma_um;
  rep.mismatch = base_loc.places;
  const double sigma = base_loc.sigma_um;
  // Energy a denoised pure-noise residual keeps is tiny; below this nothing is "visible".
  const double visible_floor = 1e-3 * sigma * sigma * static_cast<double>(n);

  EffectSelection chosen(problem, options, sel, base, base_ho, sigma, visible_floor);
  // The places explain() would set aside after this pass, were it to end with the base's residual: those of the
  // residual's local structure, else the strongest of the probe's (Pass::probe).
  EffectSelection::Settled settled;
  if (can_set_aside)
    settled = [&](const Model& m, bool with_probe) {
      const Located left = locate(problem, m.residual, options.alpha);
      if (!left.structured || !(left.visible_energy > 0)) return false;
      std::vector<Location> places;
      for (const auto& mm : left.places) places.insert(places.end(), mm.locations.begin(), mm.locations.end());
      if (places.empty() && with_probe && chosen.before_share()) {
        const Located probe = locate(problem, sel.model(*chosen.before_share()).residual, options.alpha, sigma);
        for (const auto& mm : probe.places) places.insert(places.end(), mm.locations.begin(), mm.locations.end());
        if (!places.empty())
          places = {*std::max_element(places.begin(), places.end(), [](const Location& a, const Location& b) {
            return std::abs(a.peak_um) < std::abs(b.peak_um);
          })};
      }
      return !places.empty() && can_set_aside(places);
    };
  chosen.run(settled);
  // The final fit's design (every row, the base and every term) is a pass's largest transient: the models the
  // selection kept are dropped first rather than held beside it (bench/README.md "EXPLAIN's footprint").
  sel.drop_models();
  std::vector<std::pair<std::string, Eigen::VectorXd>> steps{{"base model", sel.model({}).residual}};
  add_findings(problem, sel, chosen, sigma, visible_floor, options.keep_columns, rep, steps);
  rep.considered = chosen.considered();
  const Model& cur = chosen.model();
  rep.final_fit = {std::sqrt(cur.rss / static_cast<double>(n)), cur.bic, chosen.heldout(), cur.rank + cur.searched};
  rep.deviation_um = problem.deviation_um;
  rep.deviation_name = problem.deviation_name;
  add_curves(rep, problem, steps, options.curve_points);
  const Located fin = locate(problem, cur.residual, options.alpha);
  settle_verdict(fin, rep);
  Pass pass{std::move(rep), {}, {}, {}};
  // A generated term's columns over every sample of the problem given to explain() (a listed one's are that
  // problem's own: not copied).
  const auto term_columns = [&](const Term& t) {
    const Variant& v = variant_of(problem, t);
    Eigen::MatrixXd all;
    if (t.pool) {
      Eigen::MatrixXd scratch;
      all = v.all_samples ? v.all_samples() : columns_of(v, static_cast<Eigen::Index>(n), scratch);
    }
    return TermColumns{t.cand, t.index, t.pool != nullptr, std::move(all), v.searched};
  };
  for (const Term& t : chosen.terms()) pass.terms.push_back(term_columns(t));
  if (pass.report.unexplained && chosen.before_share()) {
    const Located probe = locate(problem, sel.model(*chosen.before_share()).residual, options.alpha, sigma);
    for (const auto& m : probe.places) pass.probe.insert(pass.probe.end(), m.locations.begin(), m.locations.end());
    for (const Term& t : *chosen.before_share()) pass.probe_terms.push_back(term_columns(t));
  }
  return pass;
}

}  // namespace guideway::models::explain::engine
