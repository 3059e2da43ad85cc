#include "models/explain/explain.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <cstdio>
#include <limits>
#include <memory>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <Eigen/QR>

#include "models/common/least_squares.hpp"
#include "models/explain/locate.hpp"
#include "models/explain/stats.hpp"

namespace guideway::models::explain {

namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

struct Fit {
  LsqResult res;
  double rss = 0;
  std::size_t k = 0;  // rank + searched nonlinear parameters
  double bic = 0;
  Eigen::VectorXd residual;
};

// The columns of the base, the effects found so far and one trial variant.
struct Design {
  Eigen::MatrixXd j;
  std::vector<std::string> names;
  std::size_t searched = 0;
};

Design assemble(const Block& base, const std::vector<const Variant*>& blocks) {
  Design d;
  Eigen::Index cols = base.columns.cols();
  for (const auto* v : blocks) cols += v->block.columns.cols();
  const Eigen::Index n = base.columns.rows() > 0 ? base.columns.rows()
                                                 : (blocks.empty() ? 0 : blocks.front()->block.columns.rows());
  d.j.resize(n, cols);
  Eigen::Index at = 0;
  if (base.columns.cols() > 0) {
    d.j.leftCols(base.columns.cols()) = base.columns;
    at = base.columns.cols();
  }
  d.names = base.names;
  for (const auto* v : blocks) {
    d.j.middleCols(at, v->block.columns.cols()) = v->block.columns;
    at += v->block.columns.cols();
    d.names.insert(d.names.end(), v->block.names.begin(), v->block.names.end());
    d.searched += v->searched;
  }
  return d;
}

Fit fit(const Design& d, const Eigen::VectorXd& y) {
  Fit f;
  const auto n = static_cast<double>(y.size());
  if (d.j.cols() == 0) {
    f.residual = y;
    f.res.ok = true;
    f.res.fitted = Eigen::VectorXd();
  } else {
    f.res = solve_lsq(d.j, y, Eigen::VectorXd(), d.names);
    if (!f.res.ok) throw std::invalid_argument("explain: least squares failed: " + f.res.message);
    f.residual = f.res.residual;
  }
  f.rss = f.residual.squaredNorm();
  f.k = f.res.rank + d.searched;
  f.bic = n * std::log(std::max(f.rss, 1e-300) / n) + static_cast<double>(f.k) * std::log(n);
  return f;
}

// The rows of each fold: fold_of[i] = the fold that holds sample i out.
struct FoldRows {
  std::vector<Eigen::Index> train, test;
  std::vector<bool> use;  // use[i]: sample i is a training row of this fold
};
std::vector<FoldRows> fold_rows(const std::vector<int>& fold_of, int folds) {
  std::vector<FoldRows> out(static_cast<std::size_t>(folds));
  for (int f = 0; f < folds; ++f) {
    auto& fr = out[static_cast<std::size_t>(f)];
    fr.use.assign(fold_of.size(), false);
    for (std::size_t i = 0; i < fold_of.size(); ++i) {
      const bool held = fold_of[i] == f;
      (held ? fr.test : fr.train).push_back(static_cast<Eigen::Index>(i));
      fr.use[i] = !held;
    }
  }
  return out;
}

// Least squares without names or uncertainties wanted (the held-out fits).
LsqResult lsq(const Eigen::MatrixXd& j, const Eigen::VectorXd& y) {
  return solve_lsq(j, y, Eigen::VectorXd(), std::vector<std::string>(static_cast<std::size_t>(j.cols()), "p"));
}
Eigen::MatrixXd hcat(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  Eigen::MatrixXd out(a.rows(), a.cols() + b.cols());
  out.leftCols(a.cols()) = a;
  out.rightCols(b.cols()) = b;
  return out;
}

// The variant choice of a selection round on the given rows, as explain() makes it on all of them:
// prescreen every variant by how much of the residual r (on those rows) it explains alone, fit the best
// `prescreen` jointly with j_rows (base + effects taken, same rows) and keep the smallest RSS. -1: none.
std::ptrdiff_t choose_variant(const std::vector<Variant>& variants, const std::vector<Eigen::Index>& rows,
                              const Eigen::VectorXd& r, const Eigen::MatrixXd& j_rows, const Eigen::VectorXd& y_rows,
                              std::size_t prescreen) {
  if (variants.size() == 1) return 0;
  std::vector<std::pair<double, std::size_t>> score;
  for (std::size_t v = 0; v < variants.size(); ++v) {
    const Eigen::MatrixXd x = variants[v].block.columns(rows, Eigen::all);
    const Eigen::VectorXd b = x.colPivHouseholderQr().solve(r);
    score.emplace_back(-(r.squaredNorm() - (r - x * b).squaredNorm()), v);
  }
  std::sort(score.begin(), score.end());
  std::ptrdiff_t best = -1;
  double best_rss = 0;
  for (std::size_t s = 0; s < std::min(prescreen, score.size()); ++s) {
    const LsqResult res = lsq(hcat(j_rows, variants[score[s].second].block.columns(rows, Eigen::all)), y_rows);
    if (!res.ok) continue;
    const double rss = res.residual.squaredNorm();
    if (best < 0 || rss < best_rss) {
      best = static_cast<std::ptrdiff_t>(score[s].second);
      best_rss = rss;
    }
  }
  return best;
}

// One fold's held-out design: the columns of the base and the effects taken so far (each effect's variant
// chosen again on the fold's training rows, see heldout()) on its training and its held-out rows, and the
// training residual of their fit. explain() keeps one per fold for the effects accepted and extends it only
// when a candidate is accepted, so a trial re-chooses only its own effect in each fold.
struct FoldFit {
  Eigen::MatrixXd jt, jh;
  Eigen::VectorXd rt;
  bool ok = false;  // false: the fold has no held-out rows
};

struct HeldOut {
  double rms = nan;
  std::string failure;  // why rms is NaN: a fold could not be fitted (not skipped: every figure compared
                        // must average the same rows)
  std::vector<FoldFit> folds;  // the prefix extended by the trial (explain() keeps it when accepted)
};

// Held-out RMS: every fold's held-out rows predicted from a fit to its training rows, the columns of the
// fold's prefix (`prefix`, one per fold; empty = the base only) and of the trial, if any. With
// ExplainOptions::heldout_reselect (the default; docs/explain.md "Held out") the trial's variant is chosen
// again in each fold from the training rows alone, as every effect of the prefix was -- a generator gets
// the training residual, zero on the held-out rows, and the mask of the training rows. Otherwise the
// variant chosen on all the data (`fixed`) is taken and only the coefficients refitted: the held-out rows
// then took part in the choice, which is optimistic (measured by bench/explain_heldout_bench.cpp).
// `columns` = base + all effects' columns as chosen on all the data. A fold that cannot be fitted (too few
// training rows, no variant, a failed fit) makes the figure NaN with HeldOut::failure saying why.
HeldOut heldout(const Problem& problem, const std::vector<FoldFit>& prefix, const Candidate* trial, const Variant* fixed,
                Eigen::Index columns, const Eigen::VectorXd& y, const std::vector<FoldRows>& folds,
                const ExplainOptions& options) {
  HeldOut out;
  if (columns == 0) {
    out.rms = std::sqrt(y.squaredNorm() / static_cast<double>(y.size()));
    return out;
  }
  out.folds.resize(folds.size());
  double sse = 0;
  std::size_t count = 0;
  for (std::size_t k = 0; k < folds.size(); ++k) {
    const auto& fold = folds[k];
    FoldFit& ff = out.folds[k];
    if (fold.test.empty() || (!prefix.empty() && !prefix[k].ok)) continue;
    const auto fail = [&](const std::string& why) {
      HeldOut failed;
      failed.failure = "fold " + std::to_string(k + 1) + " of " + std::to_string(folds.size()) + ": " + why;
      return failed;
    };
    if (fold.train.size() < static_cast<std::size_t>(columns) + 2)
      return fail(std::to_string(fold.train.size()) + " training rows for " + std::to_string(columns) + " columns");
    const Eigen::VectorXd yt = y(fold.train);
    if (prefix.empty()) {
      const bool has_base = problem.base.columns.cols() > 0;
      ff.jt = has_base ? Eigen::MatrixXd(problem.base.columns(fold.train, Eigen::all))
                       : Eigen::MatrixXd(static_cast<Eigen::Index>(fold.train.size()), 0);
      ff.jh = has_base ? Eigen::MatrixXd(problem.base.columns(fold.test, Eigen::all))
                       : Eigen::MatrixXd(static_cast<Eigen::Index>(fold.test.size()), 0);
      if (trial && options.heldout_reselect) {
        // The training residual of the base (the prefix's is kept in rt).
        ff.rt = yt;
        if (ff.jt.cols() > 0) {
          const LsqResult res = lsq(ff.jt, yt);
          if (!res.ok) return fail("the base fit failed: " + res.message);
          ff.rt = res.residual;
        }
      }
    } else {
      ff = prefix[k];
    }
    if (trial) {
      const Variant* chosen = fixed;
      std::vector<Variant> generated;
      if (options.heldout_reselect) {
        if (trial->generate) {
          Eigen::VectorXd r = Eigen::VectorXd::Zero(y.size());
          r(fold.train) = ff.rt;
          generated = trial->generate(r, fold.use);
          for (const auto& v : generated)
            if (v.block.columns.rows() != y.size())
              throw std::invalid_argument("explain: candidate " + trial->effect + " has the wrong number of rows");
        }
        const std::vector<Variant>& variants = trial->generate ? generated : trial->variants;
        const std::ptrdiff_t v =
            variants.empty() ? -1 : choose_variant(variants, fold.train, ff.rt, ff.jt, yt, options.prescreen);
        if (v < 0) return fail(trial->effect + " has no variant that can be fitted on the training rows");
        chosen = &variants[static_cast<std::size_t>(v)];
      }
      ff.jt = hcat(ff.jt, chosen->block.columns(fold.train, Eigen::all));
      ff.jh = hcat(ff.jh, chosen->block.columns(fold.test, Eigen::all));
    }
    const LsqResult r = lsq(ff.jt, yt);
    if (!r.ok) return fail("the fit failed: " + r.message);
    ff.rt = r.residual;
    ff.ok = true;
    sse += (y(fold.test) - ff.jh * r.fitted).squaredNorm();
    count += fold.test.size();
  }
  out.rms = count ? std::sqrt(sse / static_cast<double>(count)) : nan;
  return out;
}

std::string fmt(const char* f, double a) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, a);
  return buf;
}

std::vector<ParamValue> params_of(const Variant& v, const Fit& f, Eigen::Index offset) {
  const auto q = v.block.columns.cols();
  Eigen::VectorXd x = f.res.x.segment(offset, q);
  Eigen::MatrixXd cov = f.res.covariance.block(offset, offset, q, q);
  std::vector<ParamValue> out;
  if (v.report) {
    out = v.report(x, cov);
  } else {
    for (Eigen::Index i = 0; i < q; ++i)
      out.push_back({v.block.names[static_cast<std::size_t>(i)], x[i], f.res.u[offset + i]});
  }
  out.insert(out.end(), v.fixed.begin(), v.fixed.end());
  return out;
}

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

// Rounded for the JSON: curves for plots need no more than 4 decimals (0.1 nm; 1e-4 deg or mm), and stay
// compact. Divided by an exact power of ten, so the shortest decimal form is printed.
double rounded4(double v) { return std::isfinite(v) ? std::round(v * 1e4) / 1e4 : v; }

}  // namespace

Report explain(const Problem& problem, const ExplainOptions& options) {
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
      if (static_cast<std::size_t>(v.block.columns.rows()) != n)
        throw std::invalid_argument("explain: candidate " + c.effect + " has the wrong number of rows");
  const auto ranges = run_ranges(problem);

  Report rep;
  rep.model = problem.model;
  rep.n = n;
  rep.notes = problem.notes;

  // Held-out scheme: whole runs when there are at least three, the base is still determined without
  // any one of them and no candidate has terms of one run alone; otherwise contiguous blocks of every
  // run (staggered between runs).
  std::vector<int> fold_of(n, 0);
  int folds = static_cast<int>(std::max<std::size_t>(options.folds, 2));
  bool loro = false;
  const Design base_design = assemble(problem.base, {});
  if (problem.runs.size() >= 3 && !problem.terms_per_run) {
    const std::size_t full_rank = base_design.j.cols() ? fit(base_design, y).res.rank : 0;
    loro = true;
    for (std::size_t k = 0; k < ranges.size() && loro; ++k) {
      if (base_design.j.cols() == 0) break;
      std::vector<Eigen::Index> train;
      for (std::size_t i = 0; i < n; ++i)
        if (problem.samples[i].run != k) train.push_back(static_cast<Eigen::Index>(i));
      const Eigen::MatrixXd jt = base_design.j(train, Eigen::all);
      const LsqResult r = solve_lsq(jt, y(train), Eigen::VectorXd(), base_design.names);
      loro = r.ok && r.rank == full_rank;
    }
  }
  if (loro) {
    folds = static_cast<int>(problem.runs.size());
    for (std::size_t i = 0; i < n; ++i) fold_of[i] = static_cast<int>(problem.samples[i].run);
    rep.heldout_scheme = "leave-one-run-out (" + std::to_string(folds) + " runs)";
  } else {
    for (std::size_t k = 0; k < ranges.size(); ++k) {
      const auto [a, b] = ranges[k];
      const std::size_t len = b - a;
      for (std::size_t i = a; i < b; ++i) {
        const auto block = static_cast<int>((i - a) * static_cast<std::size_t>(folds) / std::max<std::size_t>(len, 1));
        fold_of[i] = (block + static_cast<int>(k)) % folds;
      }
    }
    rep.heldout_scheme = "blocked " + std::to_string(folds) + "-fold cross-validation (contiguous blocks of every run)";
  }

  std::vector<const Variant*> chosen;
  std::vector<std::shared_ptr<const std::vector<Variant>>> keep;  // generated variants that were chosen
  Fit current = fit(base_design, y);
  const std::vector<FoldRows> fold_sets = fold_rows(fold_of, folds);
  // The held-out fits of the effects taken so far, one per fold (the base's to begin with).
  HeldOut current_ho = heldout(problem, {}, nullptr, nullptr, base_design.j.cols(), y, fold_sets, options);
  Eigen::Index current_columns = base_design.j.cols();
  double current_heldout = current_ho.rms;
  // Every effect will be refused for it: say why once, whether or not a candidate gets that far.
  if (!current_ho.failure.empty()) rep.notes.push_back("held-out RMS of the base not computable (" + current_ho.failure + ")");
  rep.baseline = {std::sqrt(current.rss / static_cast<double>(n)), current.bic, current_heldout, current.k};
  std::vector<std::pair<std::string, Eigen::VectorXd>> steps{{"base model", current.residual}};  // for the curves
  const Located base_loc = locate(problem, current.residual, options.alpha);
  rep.noise_um = base_loc.sigma_um;
  rep.mismatch = base_loc.places;
  const double sigma = base_loc.sigma_um;
  // Energy a denoised pure-noise residual keeps is tiny; below this nothing is "visible".
  const double visible_floor = 1e-3 * sigma * sigma * static_cast<double>(n);

  std::vector<bool> used(problem.candidates.size(), false);
  const std::vector<bool> all_rows(n, true);
  while (chosen.size() < options.max_effects) {
    struct Trial {
      std::size_t cand = 0;
      std::shared_ptr<const std::vector<Variant>> generated;
      const Variant* variant = nullptr;
      Fit fit;
      double delta_bic = 0, p = 1;
    };
    std::vector<Trial> trials;
    std::size_t live = 0;
    for (std::size_t c = 0; c < problem.candidates.size(); ++c)
      if (!used[c] && (!problem.candidates[c].variants.empty() || problem.candidates[c].generate)) ++live;
    if (live == 0) break;
    for (std::size_t c = 0; c < problem.candidates.size(); ++c) {
      const Candidate& cand = problem.candidates[c];
      if (used[c] || (cand.variants.empty() && !cand.generate)) continue;
      std::shared_ptr<const std::vector<Variant>> generated;
      if (cand.generate) {
        generated = std::make_shared<const std::vector<Variant>>(cand.generate(current.residual, all_rows));
        for (const auto& v : *generated)
          if (static_cast<std::size_t>(v.block.columns.rows()) != n)
            throw std::invalid_argument("explain: candidate " + cand.effect + " has the wrong number of rows");
      }
      const std::vector<Variant>& variants = generated ? *generated : cand.variants;
      if (variants.empty()) continue;
      // Prescreen the variants by how much of the current residual each explains alone.
      std::vector<std::pair<double, std::size_t>> score;
      for (std::size_t v = 0; v < variants.size(); ++v) {
        const auto& x = variants[v].block.columns;
        const Eigen::VectorXd b = x.colPivHouseholderQr().solve(current.residual);
        score.emplace_back(-(current.residual.squaredNorm() - (current.residual - x * b).squaredNorm()), v);
      }
      std::sort(score.begin(), score.end());
      Trial best;
      best.cand = c;
      best.generated = generated;
      bool have = false;
      for (std::size_t s = 0; s < std::min(options.prescreen, score.size()); ++s) {
        const Variant* v = &variants[score[s].second];
        auto blocks = chosen;
        blocks.push_back(v);
        Fit f = fit(assemble(problem.base, blocks), y);
        if (!have || f.rss < best.fit.rss) {
          best.variant = v;
          best.fit = std::move(f);
          have = true;
        }
      }
      const double q = static_cast<double>(best.fit.res.rank) - static_cast<double>(current.res.rank);
      const double dof2 = static_cast<double>(n) - static_cast<double>(best.fit.res.rank);
      best.delta_bic = best.fit.bic - current.bic;
      if (q > 0 && dof2 > 0 && best.fit.rss > 0) {
        const double f = ((current.rss - best.fit.rss) / q) / (best.fit.rss / dof2);
        const double searched =
            static_cast<double>(cand.search_size ? cand.search_size : std::max<std::size_t>(variants.size(), 1));
        best.p = std::min(1.0, f_sf(f, q, dof2) * static_cast<double>(live) * searched);
      }
      trials.push_back(std::move(best));
    }
    std::sort(trials.begin(), trials.end(), [](const Trial& a, const Trial& b) { return a.delta_bic < b.delta_bic; });
    rep.considered.clear();
    bool accepted = false;
    // The structure still located in the current residual, by band (the share test's yardstick).
    const Located here = locate(problem, current.residual, options.alpha, sigma);
    const double vis_before = visible_energy(problem, current.residual, sigma, here.flagged);
    for (auto& t : trials) {
      const Candidate& cand = problem.candidates[t.cand];
      Considered con{cand.effect, t.delta_bic, t.p, ""};
      if (accepted) {
        con.verdict = "not tried after a better candidate was taken";
      } else if (!(t.p < options.alpha)) {
        con.verdict = "not significant (p=" + fmt("%.2g", t.p) + ")";
      } else if (!(t.delta_bic < 0)) {
        con.verdict = "does not lower the BIC";
      } else if (!std::isfinite(current_heldout)) {  // no figure to beat: the trial's is not computed
        con.verdict = "held-out RMS of the model so far not computable (" + current_ho.failure + ")";
      } else {
        HeldOut trial_ho = heldout(problem, current_ho.folds, &cand, t.variant,
                                   current_columns + t.variant->block.columns.cols(), y, fold_sets, options);
        const double ho = trial_ho.rms;
        double share = nan;
        if (here.structured && vis_before > visible_floor)
          share = 1.0 - visible_energy(problem, t.fit.residual, sigma, here.flagged) / vis_before;
        if (!std::isfinite(ho)) {
          con.verdict = "held-out RMS not computable (" + trial_ho.failure + ")";
        } else if (!(ho < current_heldout)) {
          con.verdict = "held-out RMS not improved (" + fmt("%.4g", ho) + " um)";
        } else if (std::isfinite(share) && share < options.min_share) {
          con.verdict = "removes only " + fmt("%.0f", 100 * share) + " % of the visible structure";
        } else {
          con.verdict = "selected";
          accepted = true;
          used[t.cand] = true;
          chosen.push_back(t.variant);
          if (t.generated) keep.push_back(t.generated);
          Finding fd;
          fd.effect = cand.effect;
          fd.delta_bic = t.delta_bic;
          fd.p_value = t.p;
          fd.rms_um_after = std::sqrt(t.fit.rss / static_cast<double>(n));
          fd.heldout_rms_um_after = ho;
          fd.share = share;
          fd.why = cand.why;
          rep.findings.push_back(fd);
          current = std::move(t.fit);
          current_heldout = ho;
          current_ho = std::move(trial_ho);
          current_columns += t.variant->block.columns.cols();
          steps.emplace_back("+ " + cand.effect, current.residual);
        }
      }
      rep.considered.push_back(con);
    }
    if (!accepted) break;
  }
  // Parameters from the final joint fit.
  Eigen::Index offset = problem.base.columns.cols();
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    rep.findings[k].parameters = params_of(*chosen[k], current, offset);
    offset += chosen[k]->block.columns.cols();
  }
  rep.final_fit = {std::sqrt(current.rss / static_cast<double>(n)), current.bic, current_heldout, current.k};
  add_curves(rep, problem, steps, options.curve_points);
  const Located fin = locate(problem, current.residual, options.alpha);
  rep.remaining = fin.places;
  rep.unexplained = fin.structured;
  return rep;
}

nlohmann::json to_json(const Report& r) {
  using nlohmann::json;
  const auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  const auto stats = [&](const FitStats& f) {
    return json{{"rms_um", num(f.rms_um)},
                {"bic", num(f.bic)},
                {"heldout_rms_um", num(f.heldout_rms_um)},
                {"parameters", f.parameters}};
  };
  const auto places = [](const std::vector<Mismatch>& v) {
    json a = json::array();
    for (const auto& m : v) {
      json ranges = json::array();
      for (const auto& [lo, hi] : m.ranges) ranges.push_back({lo, hi});
      a.push_back({{"domain", m.domain}, {"where", m.where}, {"band", m.band}, {"evidence", m.evidence}, {"ranges", ranges}});
    }
    return a;
  };
  json j;
  j["model"] = r.model;
  j["n"] = r.n;
  j["noise_um"] = num(r.noise_um);
  j["heldout_scheme"] = r.heldout_scheme;
  j["baseline"] = stats(r.baseline);
  j["mismatch"] = places(r.mismatch);
  json f = json::array();
  for (const auto& fd : r.findings) {
    json p = json::object();
    for (const auto& q : fd.parameters) p[q.name] = {{"value", num(q.value)}, {"u", num(q.u)}};
    f.push_back({{"effect", fd.effect},
                 {"parameters", p},
                 {"delta_bic", num(fd.delta_bic)},
                 {"p_value", num(fd.p_value)},
                 {"rms_um_after", num(fd.rms_um_after)},
                 {"heldout_rms_um_after", num(fd.heldout_rms_um_after)},
                 {"structure_removed", num(fd.share)},
                 {"why", fd.why}});
  }
  j["findings"] = f;
  j["final"] = stats(r.final_fit);
  j["unexplained"] = r.unexplained;
  j["remaining"] = places(r.remaining);
  json c = json::array();
  for (const auto& k : r.considered)
    c.push_back({{"effect", k.effect}, {"delta_bic", num(k.delta_bic)}, {"p_value", num(k.p_value)}, {"verdict", k.verdict}});
  j["considered"] = c;
  j["notes"] = r.notes;
  if (!r.curve_x.empty()) {
    const auto round_all = [](const std::vector<double>& v) {
      json a = json::array();
      for (double e : v) a.push_back(rounded4(e));
      return a;
    };
    json steps = json::array();
    for (const auto& st : r.curve_steps) {
      json runs = json::array();
      for (const auto& v : st.residual_um) runs.push_back(round_all(v));
      steps.push_back({{"label", st.label}, {"residual_um", runs}});
    }
    j["residuals"] = {{"domain", r.curve_domain}, {"x", round_all(r.curve_x)}, {"runs", r.curve_runs}, {"steps", steps}};
  }
  return j;
}

std::string to_text(const Report& r) {
  std::ostringstream o;
  const auto g = [](double v, const char* f = "%.4g") { return fmt(f, v); };
  o << "model " << r.model << ": " << r.n << " samples, noise " << g(r.noise_um, "%.3g") << " um (finest wavelet details)\n";
  o << "baseline: rms " << g(r.baseline.rms_um) << " um, held-out rms " << g(r.baseline.heldout_rms_um) << " um, BIC "
    << g(r.baseline.bic, "%.1f") << "  [" << r.heldout_scheme << "]\n";
  if (r.mismatch.empty()) {
    o << "\nwhere: the baseline residual is indistinguishable from noise (band energies, runs test, Ljung-Box).\n";
  } else {
    o << "\nwhere the residual is not noise:\n";
    for (const auto& m : r.mismatch)
      o << "  - " << m.domain << ": " << m.where << "\n      band " << m.band << "\n      " << m.evidence << "\n";
  }
  if (r.findings.empty()) {
    o << "\nfindings: none of the candidate effects is significant.\n";
  } else {
    o << "\nfindings (in the order they were taken):\n";
    int k = 1;
    for (const auto& f : r.findings) {
      o << "  " << k++ << ". " << f.effect << ": " << f.why << "\n";
      for (const auto& p : f.parameters) {
        o << "       " << p.name << " = " << g(p.value, "%.4g");
        if (std::isfinite(p.u)) o << " +/- " << g(p.u, "%.2g");
        else o << " (searched)";
        o << "\n";
      }
      o << "       BIC " << g(f.delta_bic, "%+.1f") << ", p = " << g(f.p_value, "%.2g") << ", rms -> " << g(f.rms_um_after)
        << " um, held-out rms -> " << g(f.heldout_rms_um_after) << " um";
      if (std::isfinite(f.share)) o << ", removes " << g(100 * f.share, "%.0f") << " % of the visible structure";
      o << "\n";
    }
  }
  if (!r.considered.empty()) {
    o << "\nlast round:\n";
    for (const auto& c : r.considered) o << "  " << c.effect << ": " << c.verdict << "\n";
  }
  o << "\nfinal: rms " << g(r.final_fit.rms_um) << " um, held-out rms " << g(r.final_fit.heldout_rms_um) << " um, BIC "
    << g(r.final_fit.bic, "%.1f") << "\n";
  if (r.unexplained) {
    o << "UNEXPLAINED: the residual is still structured and no effect in the library accounts for it:\n";
    for (const auto& m : r.remaining) o << "  - " << m.domain << ": " << m.where << " (" << m.evidence << ")\n";
  } else {
    o << "the remaining residual is consistent with noise.\n";
  }
  for (const auto& n : r.notes) o << "note: " << n << "\n";
  return o.str();
}

Variant sensor_nonlinearity_variant(const std::vector<double>& reading_um) {
  double mean = 0;
  for (double v : reading_um) mean += v;
  mean /= static_cast<double>(reading_um.size());
  Variant v;
  v.block.names = {"sensor_quadratic_per_um", "sensor_cubic_per_um2"};
  v.block.columns.resize(static_cast<Eigen::Index>(reading_um.size()), 2);
  for (std::size_t i = 0; i < reading_um.size(); ++i) {
    const double d = reading_um[i] - mean;
    v.block.columns(static_cast<Eigen::Index>(i), 0) = d * d;
    v.block.columns(static_cast<Eigen::Index>(i), 1) = d * d * d;
  }
  return v;
}

std::function<std::vector<Variant>(const Eigen::VectorXd&, const std::vector<bool>&)>
sensor_nonlinearity_generator(const Block& base, const Eigen::VectorXd& y_um, std::vector<double> offset_um) {
  if (static_cast<std::size_t>(base.columns.rows()) != static_cast<std::size_t>(y_um.size()) ||
      (!offset_um.empty() && offset_um.size() != static_cast<std::size_t>(y_um.size())))
    throw std::invalid_argument("explain: sensor_nonlinearity: base, samples and offsets differ in length");
  auto data = std::make_shared<const std::tuple<Block, Eigen::VectorXd, std::vector<double>>>(base, y_um, std::move(offset_um));
  return [data](const Eigen::VectorXd&, const std::vector<bool>& use) {
    const auto& [b, y, offset] = *data;
    if (use.size() != static_cast<std::size_t>(y.size()))
      throw std::invalid_argument("explain: sensor_nonlinearity: the row mask and the samples differ in length");
    std::vector<Eigen::Index> rows;
    for (std::size_t i = 0; i < use.size(); ++i)
      if (use[i]) rows.push_back(static_cast<Eigen::Index>(i));
    const LsqResult fit = solve_lsq(b.columns(rows, Eigen::all), y(rows), Eigen::VectorXd(), b.names);
    if (!fit.ok) return std::vector<Variant>{};
    // The prediction; on the rows in use as y - residual, the very numbers of the base fit's reading.
    const Eigen::VectorXd predicted = b.columns * fit.fitted;
    std::vector<double> reading(static_cast<std::size_t>(y.size()));
    for (std::size_t i = 0; i < reading.size(); ++i) {
      const auto r = static_cast<Eigen::Index>(i);
      reading[i] = (use[i] ? y[r] - (y[r] - predicted[r]) : predicted[r]) + (offset.empty() ? 0.0 : offset[i]);
    }
    return std::vector<Variant>{sensor_nonlinearity_variant(reading)};
  };
}

void refit_sensor_nonlinearity(Problem& p, const Block& base, const Eigen::VectorXd& y_um, std::vector<double> offset_um) {
  for (auto& c : p.candidates)
    if (c.effect == "sensor_nonlinearity") {
      c.variants.clear();
      c.generate = sensor_nonlinearity_generator(base, y_um, std::move(offset_um));
      return;
    }
}

std::vector<ParamValue> amp_phase(const std::string& amp_name, const std::string& phase_name, const Eigen::VectorXd& x,
                                  const Eigen::MatrixXd& cov) {
  const double cs = x[0], cc = x[1];
  const double a = std::hypot(cs, cc);
  double ua = std::numeric_limits<double>::quiet_NaN(), up = ua;
  if (a > 0) {
    Eigen::Vector2d ga(cs / a, cc / a), gp(-cc / (a * a), cs / (a * a));
    ua = std::sqrt(std::max(0.0, ga.dot(cov.topLeftCorner(2, 2) * ga)));
    up = std::sqrt(std::max(0.0, gp.dot(cov.topLeftCorner(2, 2) * gp))) * 180 / std::numbers::pi;
  }
  return {{amp_name, a, ua}, {phase_name, std::atan2(cc, cs) * 180 / std::numbers::pi, up}};
}

}  // namespace guideway::models::explain
