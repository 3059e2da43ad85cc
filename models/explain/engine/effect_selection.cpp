// The set of effects EXPLAIN reports (effect_selection.hpp).
#include "models/explain/engine/effect_selection.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/number_format.hpp"
#include "models/explain/engine/set_aside.hpp"
#include "models/explain/engine/term_tests.hpp"
#include "models/explain/locate.hpp"

namespace guideway::models::explain::engine {

namespace {

// What a model of `terms` fits, in words: the base (with the reading's offsets after places set aside, when the
// problem has them) and the effects taken.
std::string fitted_by(const Problem& p, const std::vector<Term>& terms) {
  const bool offsets = std::any_of(p.base.names.begin(), p.base.names.end(), [](const std::string& name) {
    return name.rfind(offset_after_set_aside_prefix, 0) == 0;
  });
  std::string out = offsets ? "the base and the reading's offsets after the places set aside" : "the base";
  for (std::size_t k = 0; k < terms.size(); ++k)
    out += (k + 1 < terms.size() ? ", " : " and ") + p.candidates[terms[k].cand].effect;
  return out;
}

}  // namespace

EffectSelection::EffectSelection(const Problem& problem, const ExplainOptions& options, const Selection& sel,
                                 Model base, HeldOut base_heldout, double sigma, double visible_floor)
    : p_(problem),
      o_(options),
      sel_(sel),
      sigma_(sigma),
      visible_floor_(visible_floor),
      nc_(problem.candidates.size()),
      cur_(std::move(base)),
      cur_ho_(std::move(base_heldout)),
      cur_heldout_(cur_ho_.rms),
      banned_(nc_, false),
      verdict_(nc_) {}

// The forward steps run until none takes an effect; another round of them only when the share rule has dropped
// one since: with nothing dropped the state is the one the last step left, and the same steps would take nothing
// again (each candidate is taken at most once and dropped at most once, so the rounds are at most nc_ + 1).
void EffectSelection::run(const Settled& settled) {
  bool changed = true, ended = false;
  std::size_t in_a_row = 0;  // effects joined, one after another, that the share rule would drop with every other
  for (std::size_t guard = 0; changed && guard < 4 * nc_ + 4; ++guard) {
    while (terms_.size() < o_.max_effects) {
      const std::string accepted = forward_step();
      if (accepted.empty()) break;
      // Earlier choices re-decided with the new effect in the model (a deadband sized, a line picked,
      // while this effect was still in the residual), then re-tested.
      for (std::size_t k = 0; k + 1 < terms_.size(); ++k) sel_.rechoose(terms_, k);
      // The new effect with each earlier one (pairs of earlier effects were searched when the later joined).
      for (std::size_t i = 0; i + 1 < terms_.size(); ++i) sel_.rechoose_pair(terms_, i, terms_.size() - 1);
      refresh();
      prune(accepted);
      in_a_row = settled && partial_fits_only(settled, in_a_row + 1 >= 2) ? in_a_row + 1 : 0;
      ended = in_a_row >= 2;
      if (ended) break;
    }
    if (ended) break;
    const bool had_terms = !terms_.empty();
    changed = drop_partial_fits();
    if (settled && had_terms && terms_.empty() && settled(cur_, true)) break;
  }
  // The findings in the order taken.
  std::sort(terms_.begin(), terms_.end(), [](const Term& a, const Term& b) { return a.taken < b.taken; });
}

// The latest verdict of every candidate without a term, lowest delta BIC first.
std::vector<Considered> EffectSelection::considered() const {
  std::vector<Considered> out;
  for (std::size_t c = 0; c < nc_; ++c)
    if (verdict_[c] && !has_term(c)) out.push_back(*verdict_[c]);
  std::stable_sort(out.begin(), out.end(),
                   [](const Considered& a, const Considered& b) { return a.delta_bic < b.delta_bic; });
  return out;
}

void EffectSelection::refresh() {
  cur_ = sel_.model(terms_);
  cur_ho_ = sel_.heldout(terms_, none);
  cur_heldout_ = cur_ho_.rms;
}

void EffectSelection::drop(std::size_t k, Considered why) {
  const std::size_t c = terms_[k].cand;
  terms_.erase(terms_.begin() + static_cast<std::ptrdiff_t>(k));
  banned_[c] = true;
  if (!has_term(c)) verdict_[c] = std::move(why);
  refresh();
}

// Drop-one: every effect kept must still pass the tests with the others in the model.
void EffectSelection::prune(const std::string& after) {
  while (!terms_.empty()) {
    std::size_t worst = none;
    DropTest wd;
    for (std::size_t k = 0; k < terms_.size(); ++k) {
      DropTest d = drop_test(sel_, terms_, k, cur_, cur_heldout_);
      if (!d.earns && (worst == none || d.p > wd.p)) {
        worst = k;
        wd = std::move(d);
      }
    }
    if (worst == none) return;
    drop(worst,
         {p_.candidates[terms_[worst].cand].effect, wd.delta_bic, wd.p, "dropped after " + after + ": " + wd.why});
  }
}

// Every candidate not banned tried against the model, Bonferroni over the trials, lowest BIC first; `unfittable`
// gets those no variant of which can be fitted beside the model.
std::vector<Trial> EffectSelection::trials(std::vector<std::size_t>& unfittable) const {
  std::vector<Trial> out;
  for (std::size_t c = 0; c < nc_; ++c) {
    const Candidate& cand = p_.candidates[c];
    if (banned_[c]) continue;
    if (cand.variants.empty() && !cand.generate) {  // nothing to try: listed all the same, with why
      unfittable.push_back(c);
      continue;
    }
    if (o_.on_progress)
      o_.on_progress("looking for effect " + std::to_string(terms_.size() + 1) + ": trying " + cand.effect + " (" +
                     std::to_string(c + 1) + " of " + std::to_string(nc_) + ")");
    Trial t = sel_.trial(c, terms_, cur_);
    if (t.index != none)
      out.push_back(std::move(t));
    else
      unfittable.push_back(c);
  }
  for (auto& t : out) {
    t.bonferroni *= static_cast<double>(out.size());
    t.p = std::min(1.0, t.p * t.bonferroni);
  }
  std::sort(out.begin(), out.end(), [](const Trial& a, const Trial& b) { return a.delta_bic < b.delta_bic; });
  return out;
}

// One forward step: the best trial that passes the F-test, lowers the BIC, has its searched values inside its grid
// (past_grid_edge) and improves the held-out RMS joins the model; every other trial's verdict is kept. Returns the
// effect taken ("" = none).
std::string EffectSelection::forward_step() {
  std::string accepted;
  std::vector<std::size_t> unfittable;
  std::vector<Trial> tried = trials(unfittable);
  // Listed all the same (docs/explain.md: `considered` lists every candidate): its columns add nothing to what the
  // model fits, so no test can be made of it.
  for (const std::size_t c : unfittable)
    if (!has_term(c))
      verdict_[c] = Considered{p_.candidates[c].effect, 0.0, 1.0,
                               p_.candidates[c].variants.empty() && !p_.candidates[c].generate
                                   ? std::string("cannot be fitted: the problem offers no form of it")
                                   : "cannot be fitted: every variant lies in what " + fitted_by(p_, terms_) + " fit"};
  for (auto& t : tried) {
    const Candidate& cand = p_.candidates[t.cand];
    Considered con{cand.effect, t.delta_bic, t.p, ""};
    if (!accepted.empty()) {
      con.verdict = "not tried after a better candidate was taken";
    } else if (!(t.p < o_.alpha)) {
      con.verdict = "not significant (p=" + printf_number("%.2g", t.p) + ")";
    } else if (!(t.delta_bic < 0)) {
      con.verdict = "does not lower the BIC";
    } else if (std::string edge = past_grid_edge(sel_, cur_, listed(cand, t.pool)[t.index], t.ext.rss);
               !edge.empty()) {
      con.verdict = std::move(edge);
    } else if (!std::isfinite(cur_heldout_)) {  // no figure to beat: the trial's is not computed
      con.verdict = "held-out RMS of the model so far not computable (" + cur_ho_.failure + ")";
    } else {
      const Variant& v = listed(cand, t.pool)[t.index];
      HeldOut ho = sel_.heldout(terms_, none, t.cand, &v);
      if (!std::isfinite(ho.rms)) {
        con.verdict = "held-out RMS not computable (" + ho.failure + ")";
      } else if (!(ho.rms < cur_heldout_)) {
        con.verdict = "held-out RMS not improved (" + printf_number("%.4g", ho.rms) + " um)";
      } else {
        con.verdict = "selected";
        accepted = cand.effect;
        terms_.push_back({t.cand, t.pool, t.index, t.bonferroni, taken_++, std::move(ho.trial)});
        verdict_[t.cand].reset();
        continue;
      }
    }
    if (!has_term(t.cand)) verdict_[t.cand] = std::move(con);
  }
  return accepted;
}

// Each effect must remove most of the structure left without it: a partial fit of a cause it is not
// leaves that cause's shape behind. Not when nothing is left above the noise: no shape is left behind, and
// the share is then of the noise (a traverse's drift at t = 7.7 "removed only 69-80 %" at 26 of 100 seeds).
// Returns whether one was dropped.
bool EffectSelection::drop_partial_fits() {
  bool changed = false;
  while (!terms_.empty()) {
    const Located left = locate(p_, cur_.residual, o_.alpha, sigma_);
    if (!left.structured || !(left.visible_energy > 0)) break;
    std::size_t worst = none;
    double worst_share = 1.0;
    for (std::size_t k = 0; k < terms_.size(); ++k) {
      const double s = share(sel_, terms_, k, cur_, sigma_, visible_floor_);
      if (std::isfinite(s) && s < o_.min_share && (worst == none || s < worst_share)) {
        worst = k;
        worst_share = s;
      }
    }
    if (worst == none) break;
    if (!before_share_) before_share_ = terms_;
    const std::string effect = p_.candidates[terms_[worst].cand].effect;
    const DropTest d = significance(sel_, terms_, worst, cur_);
    drop(worst, {effect, d.delta_bic, d.p,
                 "removes only " + printf_number("%.0f", 100 * worst_share) + " % of the structure left without it"});
    prune("dropping " + effect);
    changed = true;
  }
  return changed;
}

// The share rule applied now, after an effect joined: when it drops every effect held and the base's residual is
// structured at places of its own that explain() would set aside, the selection ends there, as it would have once
// the forward steps ran out (the effects taken beside such a fault are partial fits of it, and what they leave is
// the fault again, only fitted more ways: its samples grow with n, so more such fits pass the tests, each tried
// on every fold). Otherwise everything the share rule did is undone and the steps go on.
bool EffectSelection::partial_fits_only(const Settled& settled, bool end_there) {
  if (terms_.empty()) return false;
  std::vector<Term> terms = terms_;
  Model cur = cur_;
  HeldOut cur_ho = cur_ho_;
  const double cur_heldout = cur_heldout_;
  std::vector<bool> banned = banned_;
  std::vector<std::optional<Considered>> verdict = verdict_;
  std::optional<std::vector<Term>> before_share = before_share_;
  drop_partial_fits();
  const bool only = terms_.empty() && settled(cur_, false);
  if (only && end_there) return true;
  terms_ = std::move(terms);
  cur_ = std::move(cur);
  cur_ho_ = std::move(cur_ho);
  cur_heldout_ = cur_heldout;
  banned_ = std::move(banned);
  verdict_ = std::move(verdict);
  before_share_ = std::move(before_share);
  return only;
}

bool EffectSelection::has_term(std::size_t c) const {
  return std::any_of(terms_.begin(), terms_.end(), [&](const Term& t) { return t.cand == c; });
}

}  // namespace guideway::models::explain::engine
