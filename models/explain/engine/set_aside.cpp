// EXPLAIN's set-aside rounds (set_aside.hpp).
#include "models/explain/engine/set_aside.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

#include "core/number_format.hpp"
#include "models/common/least_squares.hpp"
#include "models/explain/engine/subspace.hpp"
#include "models/explain/locate.hpp"
#include "models/explain/stats.hpp"

namespace guideway::models::explain::engine {

bool stands_off(const Problem& p, OffsetAfter after, std::size_t sample) {
  const std::size_t r = p.samples[sample].run;
  return r > after.first || (after.second != later_runs && r == after.first && sample >= after.second);
}

namespace {

// The samples [from, to) a place sets aside: the place and a margin on either side (its own length, at most
// 1/32 of its run: the tails of a step or a ring-down beyond half its peak).
std::pair<std::size_t, std::size_t> stretch_of(const Problem& p,
                                               const std::vector<std::pair<std::size_t, std::size_t>>& ranges,
                                               const Location& l) {
  const auto [a, b] = ranges[p.samples[l.first_sample].run];
  const std::size_t len = l.end_sample - l.first_sample, margin = std::min(len, (b - a) / 32);
  return {l.first_sample - std::min(margin, l.first_sample - a), std::min(b, l.end_sample + margin)};
}

// Of the places set aside, those the findings made without them do not explain. The last pass's model (the base,
// the reading's offsets after each place, the findings' terms), fitted to the samples kept, predicts every
// sample; a place whose stretch it predicts to within the noise (its residual's sum of squares against sigma^2
// times its samples, chi-square, Bonferroni over the places) was the structure of an effect found later (in the
// first pass, the backlash's lobes of the other run beside a slip), not a fault. All kept when the fit fails.
std::vector<bool> unexplained_places(const Problem& p, const Pass& pass, const std::vector<Location>& places,
                                     const std::vector<bool>& keep, const std::vector<OffsetAfter>& after, double sigma,
                                     double alpha) {
  std::vector<bool> out(places.size(), true);
  const auto n = static_cast<Eigen::Index>(p.samples.size());
  if (!(sigma > 0) || places.size() < 2) return out;
  Eigen::Index cols = p.base.columns.cols() + static_cast<Eigen::Index>(after.size());
  std::vector<Eigen::MatrixXd> scratch;
  const std::vector<const Eigen::MatrixXd*> term_columns = columns_of_terms(p, pass.terms, n, scratch);
  if (term_columns.size() != pass.terms.size()) return out;
  for (const Eigen::MatrixXd* c : term_columns) cols += c->cols();
  // The fit to the samples kept is the fit to every sample with the others weighted 0: then the base is read where
  // the problem holds it, and no n x p copy of the design (nor of its kept rows) is made beside it.
  Eigen::MatrixXd offsets(n, static_cast<Eigen::Index>(after.size()));
  for (std::size_t k = 0; k < after.size(); ++k)
    for (Eigen::Index i = 0; i < n; ++i)
      offsets(i, static_cast<Eigen::Index>(k)) = stands_off(p, after[k], static_cast<std::size_t>(i)) ? 1.0 : 0.0;
  Eigen::VectorXd y = observations(p);
  // Where the stations' means are fitted out of the data, the fit to the samples kept has them of those samples: each
  // column (and y) less its station's mean over the rows kept, on every row, so that a place set aside is predicted
  // from its station's readings kept, as a term per station would predict it.
  std::vector<Eigen::MatrixXd> absorbed;
  if (p.station_means_absorbed) {
    absorbed.reserve(term_columns.size() + 1);
    if (p.base.columns.cols() > 0) absorbed.push_back(p.base.columns);
    for (const Eigen::MatrixXd* c : term_columns) absorbed.push_back(*c);
    for (Eigen::MatrixXd& c : absorbed) absorb_station_means(p.station_of, &keep, c);
    absorb_station_means(p.station_of, &keep, offsets);
    Eigen::Map<Eigen::MatrixXd> ym(y.data(), n, 1);
    absorb_station_means(p.station_of, &keep, ym);
  }
  ColumnBlocks design;
  if (p.station_means_absorbed) {
    for (const Eigen::MatrixXd& c : absorbed)
      if (c.cols() > 0) design.emplace_back(c);
    if (offsets.cols() > 0) design.emplace_back(offsets);
  } else {
    if (p.base.columns.cols() > 0) design.emplace_back(p.base.columns);
    if (offsets.cols() > 0) design.emplace_back(offsets);
    for (const Eigen::MatrixXd* c : term_columns)
      if (c->cols() > 0) design.emplace_back(*c);
  }
  Eigen::VectorXd kept(n);
  for (Eigen::Index i = 0; i < n; ++i) kept[i] = keep[static_cast<std::size_t>(i)] ? 1.0 : 0.0;
  const LsqResult fit = solve_lsq(design, y, kept, std::vector<std::string>(static_cast<std::size_t>(cols)));
  if (!fit.ok) return out;
  const Eigen::VectorXd& residual = fit.residual;  // on every sample
  const auto ranges = run_ranges(p);
  for (std::size_t k = 0; k < places.size(); ++k) {
    const auto [from, to] = stretch_of(p, ranges, places[k]);
    const double chi2 =
        residual.segment(static_cast<Eigen::Index>(from), static_cast<Eigen::Index>(to - from)).squaredNorm() /
        (sigma * sigma);
    out[k] = chi2_sf(chi2, static_cast<double>(to - from)) * static_cast<double>(places.size()) < alpha;
  }
  return out;
}

}  // namespace

namespace {

// A variant of the whole problem (`n` samples) on the samples `kept`, made on demand from `whole` (which writes its
// block, w columns, over every sample); that block is also its Variant::all_samples. `like`: the variant it stands
// for (its names, searched values, report: not its columns).
Variant cropped(const Variant& like, Eigen::Index w, std::function<void(Eigen::Ref<Eigen::MatrixXd>)> whole,
                const std::shared_ptr<const std::vector<Eigen::Index>>& kept, Eigen::Index n) {
  Variant out;
  out.block.names = like.block.names;
  out.fixed = like.fixed;
  out.searched = like.searched;
  out.group = like.group;
  out.report = like.report;
  out.fill = [whole, kept, n, w](Eigen::Ref<Eigen::MatrixXd> o) {
    Eigen::MatrixXd all(n, w);
    whole(all);
    o = all(*kept, Eigen::all);
  };
  out.all_samples = [whole, n, w] {
    Eigen::MatrixXd all(n, w);
    whole(all);
    return all;
  };
  return out;
}

// A listed variant's rows read from the whole problem's (which outlives the reduced one); a generated one's from
// what it was made over, moved into the new one.
Variant cropped_listed(const Variant& v, const std::shared_ptr<const std::vector<Eigen::Index>>& kept, Eigen::Index n) {
  Variant out = cropped(
      v, width(v), [listed = &v](Eigen::Ref<Eigen::MatrixXd> o) { write_columns(*listed, o); }, kept, n);
  for (const Variant& b : v.beyond) out.beyond.push_back(cropped_listed(b, kept, n));
  return out;
}
Variant cropped_generated(Variant v, const std::shared_ptr<const std::vector<Eigen::Index>>& kept, Eigen::Index n) {
  std::vector<Variant> beyond;
  for (Variant& b : v.beyond) beyond.push_back(cropped_generated(std::move(b), kept, n));
  const Eigen::Index w = width(v);
  std::function<void(Eigen::Ref<Eigen::MatrixXd>)> whole;
  if (v.fill) {
    whole = std::move(v.fill);
  } else {
    whole = [columns = std::make_shared<const Eigen::MatrixXd>(std::move(v.block.columns))](
                Eigen::Ref<Eigen::MatrixXd> o) { o = *columns; };
  }
  Variant out = cropped(v, w, std::move(whole), kept, n);
  out.beyond = std::move(beyond);
  return out;
}

}  // namespace

// Nothing of the variants is copied: the reduced problem's read the whole problem's rows when used.
Reduced without_samples(const Problem& p, const std::vector<bool>& keep, const std::vector<OffsetAfter>& after) {
  Reduced out;
  out.kept.reserve(static_cast<std::size_t>(std::count(keep.begin(), keep.end(), true)));
  for (std::size_t i = 0; i < keep.size(); ++i)
    if (keep[i]) out.kept.push_back(static_cast<Eigen::Index>(i));
  const auto kept = std::make_shared<const std::vector<Eigen::Index>>(out.kept);
  const auto n = static_cast<Eigen::Index>(p.samples.size());
  Problem& q = out.problem;
  q.model = p.model;
  q.domain = p.domain;
  q.timed = p.timed;
  q.runs = p.runs;
  q.notes = p.notes;
  q.clock_origin_s = p.clock_origin_s;
  q.terms_per_run = p.terms_per_run;
  q.deviation_um = p.deviation_um;
  q.deviation_name = p.deviation_name;
  q.samples.reserve(kept->size());
  for (const Eigen::Index i : *kept) q.samples.push_back(p.samples[static_cast<std::size_t>(i)]);
  q.path_of_run = p.path_of_run;
  if (!p.station_of.empty())
    for (const Eigen::Index i : *kept) q.station_of.push_back(p.station_of[static_cast<std::size_t>(i)]);
  q.base.names = p.base.names;
  q.base.columns.resize(static_cast<Eigen::Index>(kept->size()),
                        p.base.columns.cols() + static_cast<Eigen::Index>(after.size()));
  if (p.base.columns.cols() > 0) q.base.columns.leftCols(p.base.columns.cols()) = p.base.columns(*kept, Eigen::all);
  for (std::size_t k = 0; k < after.size(); ++k) {
    const Eigen::Index b = p.base.columns.cols() + static_cast<Eigen::Index>(k);
    for (std::size_t i = 0; i < kept->size(); ++i)
      q.base.columns(static_cast<Eigen::Index>(i), b) =
          stands_off(p, after[k], static_cast<std::size_t>((*kept)[i])) ? 1.0 : 0.0;
    q.base.names.push_back(offset_after_set_aside_prefix + std::to_string(k + 1) + "_um");
  }
  for (const Candidate& c : p.candidates) {
    Candidate& d = q.candidates.emplace_back();
    d.effect = c.effect;
    d.why = c.why;
    d.search_size = c.search_size;
    for (const Variant& v : c.variants) d.variants.push_back(cropped_listed(v, kept, n));
    if (!c.generate) continue;
    d.generate = [generate = c.generate, kept, n](const Eigen::VectorXd& r, const std::vector<bool>& use) {
      Eigen::VectorXd whole = Eigen::VectorXd::Zero(n);
      std::vector<bool> in_use(static_cast<std::size_t>(n), false);
      for (std::size_t i = 0; i < kept->size(); ++i) {
        whole[(*kept)[i]] = r[static_cast<Eigen::Index>(i)];
        in_use[static_cast<std::size_t>((*kept)[i])] = use[i];
      }
      std::vector<Variant> vs;
      for (Variant& v : generate(whole, in_use)) vs.push_back(cropped_generated(std::move(v), kept, n));
      return vs;
    };
  }
  if (p.contribution_of) {
    std::vector<std::size_t> nearest(static_cast<std::size_t>(n));  // for each sample, the kept one standing in
    std::size_t k = 0;
    for (std::size_t i = 0; i < nearest.size(); ++i) {
      while (k + 1 < kept->size() && (static_cast<std::size_t>((*kept)[k]) < i ||
                                      p.samples[static_cast<std::size_t>((*kept)[k])].run < p.samples[i].run))
        ++k;
      nearest[i] = k;
    }
    q.contribution_of = [of = p.contribution_of, nearest = std::move(nearest)](const Eigen::VectorXd& term) {
      Eigen::VectorXd whole(static_cast<Eigen::Index>(nearest.size()));
      for (std::size_t i = 0; i < nearest.size(); ++i)
        whole[static_cast<Eigen::Index>(i)] = term[static_cast<Eigen::Index>(nearest[i])];
      return of(whole);
    };
  }
  // The stations' means again, of the samples kept: less the whole's means, each less its kept rows' mean, is each
  // less the kept rows' own mean (a station's constant is a constant).
  if (p.station_means_absorbed) absorb_station_means(q);
  return out;
}

// Where a pass left structure no effect explains, place by place, in the whole problem's samples
// (`index`: the whole problem's index of each sample of the pass's problem): the places of its remaining
// structure, or when that is structured throughout, those of the probe (Pass::probe).
std::vector<Location> remaining_places(const Pass& pass, const std::vector<Eigen::Index>& index, bool& from_probe) {
  std::vector<Location> places;
  for (const auto& m : pass.report.remaining) places.insert(places.end(), m.locations.begin(), m.locations.end());
  from_probe = places.empty();
  if (from_probe) places = pass.probe;
  for (Location& l : places) {
    l.first_sample = static_cast<std::size_t>(index[l.first_sample]);
    l.end_sample = static_cast<std::size_t>(index[l.end_sample - 1]) + 1;
  }
  return places;
}

std::vector<Location> strongest_probe_place(const Pass& pass, const std::vector<Eigen::Index>& index) {
  if (pass.probe.empty()) return {};
  Location l = *std::max_element(pass.probe.begin(), pass.probe.end(), [](const Location& a, const Location& b) {
    return std::abs(a.peak_um) < std::abs(b.peak_um);
  });
  l.first_sample = static_cast<std::size_t>(index[l.first_sample]);
  l.end_sample = static_cast<std::size_t>(index[l.end_sample - 1]) + 1;
  return {l};
}

// Sets aside each place's stretch. Returns the samples set aside in all.
std::size_t set_aside(const Problem& p, const std::vector<Location>& places, std::vector<bool>& keep) {
  const auto ranges = run_ranges(p);
  for (const auto& l : places) {
    const auto [from, to] = stretch_of(p, ranges, l);
    for (std::size_t i = from; i < to; ++i) keep[i] = false;
  }
  return static_cast<std::size_t>(std::count(keep.begin(), keep.end(), false));
}

// A place's run and the first sample after the stretch set aside about it (or its run's end): where the
// reading may stand off (without_samples).
OffsetAfter offset_after(const Problem& p, const Location& l, const std::vector<bool>& keep) {
  const std::size_t run = p.samples[l.first_sample].run;
  std::size_t i = l.end_sample;
  while (i < keep.size() && !keep[i] && p.samples[i].run == run) ++i;
  return {run, i};
}

namespace {

// What fitted_offsets leaves of a column beyond the base: below this fraction, the offsets take it.
constexpr double least_left_beyond_offsets = 1.0 / 32;

// `x`'s columns with their part in the span of the orthonormal `q` taken off.
Eigen::MatrixXd beyond(const Eigen::MatrixXd& q, Eigen::MatrixXd x) {
  if (q.cols() > 0) x -= q * (q.transpose() * x);
  return x;
}

// The basis of the offsets `chosen` of `offsets` (their columns beyond the base).
Eigen::MatrixXd basis_of(const Eigen::MatrixXd& offsets, const std::vector<bool>& chosen) {
  std::vector<Eigen::Index> cols;
  for (std::size_t k = 0; k < chosen.size(); ++k)
    if (chosen[k]) cols.push_back(static_cast<Eigen::Index>(k));
  return cols.empty() ? Eigen::MatrixXd(offsets.rows(), 0) : span_basis(offsets(Eigen::all, cols));
}

// The least fraction of a column of `x` (columns beyond the base) left beyond the span of the orthonormal `q`.
double least_left(const Eigen::MatrixXd& x, const Eigen::MatrixXd& q) {
  const Eigen::MatrixXd left = beyond(q, x);
  double least = 1.0;
  for (Eigen::Index j = 0; j < x.cols(); ++j)
    least = std::min(least, left.col(j).squaredNorm() / x.col(j).squaredNorm());
  return least;
}

}  // namespace

namespace {

// The nuisance columns of the places `after`: per place, the step from the sample after it on (in its run and every
// later one); then per run with a place, the level of the runs after it, apart (a ball seated again between runs);
// none that the samples kept leave empty or make the same as another. With the first sample each starts at (the
// order they are taken in: a level after the steps, so that where it would take a candidate's column it is the one
// left out, and the steps are what they were).
std::vector<std::pair<OffsetAfter, std::size_t>> nuisance_columns(const Problem& p, const std::vector<bool>& keep,
                                                                  const std::vector<OffsetAfter>& after) {
  std::vector<OffsetAfter> wanted = after;
  for (const OffsetAfter& a : after) wanted.emplace_back(a.first, later_runs);
  std::vector<std::pair<OffsetAfter, std::size_t>> out;
  std::vector<std::vector<bool>> masks;
  for (const OffsetAfter& c : wanted) {
    std::vector<bool> mask(keep.size(), false);
    std::size_t first = keep.size();
    for (std::size_t i = 0; i < keep.size(); ++i)
      if (keep[i] && stands_off(p, c, i)) {
        mask[i] = true;
        first = std::min(first, i);
      }
    if (first == keep.size() || std::find(masks.begin(), masks.end(), mask) != masks.end()) continue;
    masks.push_back(std::move(mask));
    out.emplace_back(c, first);
  }
  return out;
}

}  // namespace

std::vector<OffsetAfter> fitted_offsets(const Problem& p, const std::vector<bool>& keep,
                                        const std::vector<OffsetAfter>& places, std::vector<std::string>* notes) {
  const auto columns = nuisance_columns(p, keep, places);
  std::vector<OffsetAfter> after;
  for (const auto& c : columns) after.push_back(c.first);
  if (after.empty()) return after;
  const auto n = static_cast<Eigen::Index>(p.samples.size());
  const std::vector<Eigen::Index> rows = rows_in_use(keep);
  const auto m = static_cast<Eigen::Index>(rows.size());
  // Where the stations' means are fitted out of the data, every column is taken as the kept rows' fit sees it: less
  // its station's mean over them (an offset from the turnaround on is then, like a rocking, half a step each way).
  std::vector<std::size_t> kept_stations;
  if (p.station_means_absorbed)
    for (const Eigen::Index i : rows) kept_stations.push_back(p.station_of[static_cast<std::size_t>(i)]);
  const auto absorbed = [&](Eigen::MatrixXd x) {
    if (!kept_stations.empty()) absorb_station_means(kept_stations, nullptr, x);
    return x;
  };
  const Eigen::MatrixXd base_q =
      p.base.columns.cols() > 0 ? span_basis(absorbed(p.base.columns(rows, Eigen::all))) : Eigen::MatrixXd(m, 0);
  Eigen::MatrixXd offsets(m, static_cast<Eigen::Index>(after.size()));
  for (std::size_t k = 0; k < after.size(); ++k)
    for (Eigen::Index i = 0; i < m; ++i)
      offsets(i, static_cast<Eigen::Index>(k)) =
          stands_off(p, after[k], static_cast<std::size_t>(rows[static_cast<std::size_t>(i)])) ? 1.0 : 0.0;
  offsets = beyond(base_q, absorbed(std::move(offsets)));
  const Eigen::MatrixXd all = basis_of(offsets, std::vector<bool>(after.size(), true));
  // The listed variants all the offsets take (those they do not, no fewer of them can), each by its candidate:
  // their columns beyond the base.
  std::vector<std::pair<std::size_t, Eigen::MatrixXd>> taken;
  for (std::size_t c = 0; c < p.candidates.size(); ++c) {
    for (const Variant& v : p.candidates[c].variants) {
      Eigen::MatrixXd scratch;
      const Eigen::MatrixXd& whole = columns_of(v, n, scratch);
      if (whole.rows() != n) continue;
      const Eigen::MatrixXd kept = absorbed(whole(rows, Eigen::all));
      Eigen::MatrixXd x = beyond(base_q, kept);
      // A column the base itself fits is the base's matter, not the offsets'.
      std::vector<Eigen::Index> free;
      for (Eigen::Index j = 0; j < x.cols(); ++j)
        if (x.col(j).squaredNorm() > rank_tolerance * kept.col(j).squaredNorm()) free.push_back(j);
      if (free.empty()) continue;
      x = Eigen::MatrixXd(x(Eigen::all, free));
      if (least_left(x, all) < least_left_beyond_offsets) taken.emplace_back(c, std::move(x));
    }
  }
  // The offsets taken in the order of the samples they start at (the steps, then the levels of the runs after them),
  // each kept when, with those kept before it, it leaves every column enough: the one that completes a candidate's
  // column is left out.
  std::vector<bool> chosen(after.size(), taken.empty());
  std::vector<std::size_t> order(after.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  // A level right after the first step of its run: where the pieces the steps cut the runs into would leave a
  // candidate too little (a drift's ramp), a later place's step is left out rather than the runs' level.
  std::vector<double> key(after.size());
  for (std::size_t k = 0; k < after.size(); ++k) {
    key[k] = static_cast<double>(columns[k].second);
    if (after[k].second != later_runs) continue;
    for (std::size_t j = 0; j < after.size(); ++j)
      if (after[j].second != later_runs && after[j].first == after[k].first)
        key[k] = std::min(key[k], static_cast<double>(columns[j].second) + 0.5);
  }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return key[a] < key[b]; });
  for (const std::size_t k : taken.empty() ? std::vector<std::size_t>{} : order) {
    chosen[k] = true;
    const Eigen::MatrixXd q = basis_of(offsets, chosen);
    const auto it = std::find_if(taken.begin(), taken.end(),
                                 [&](const auto& t) { return least_left(t.second, q) < least_left_beyond_offsets; });
    if (it == taken.end()) continue;
    chosen[k] = false;
    if (!notes) continue;
    const auto [run, from] = after[k];
    const std::string unit = p.domain == "angle_deg" ? " deg" : " mm";
    const std::string where = from != later_runs && from < p.samples.size() && p.samples[from].run == run
                                  ? p.runs[run].label + " from " + printf_number("%.4g", p.samples[from].where) + unit + " on"
                                  : "the runs after " + p.runs[run].label;
    std::string note = "the reading's offset after a place set aside (" + where +
                       ") was not fitted: on the samples kept it is, with the base and the offsets before it, " +
                       p.candidates[it->first].effect +
                       "'s own column, and a step there cannot be told from that effect";
    // Two places whose offsets start at the same sample (one stretch set aside in two rounds) are one note.
    if (std::find(notes->begin(), notes->end(), note) == notes->end()) notes->push_back(std::move(note));
  }
  std::vector<OffsetAfter> out;
  for (std::size_t k = 0; k < after.size(); ++k)
    if (chosen[k]) out.push_back(after[k]);
  return out;
}

// A run the structure tests could look at that setting aside would leave too short for them (a traverse's
// pass of 33 readings): its label, or "" when there is none.
std::string starved_run(const Problem& p, const std::vector<bool>& keep) {
  for (const TestedStretch& s : tested_stretches(p)) {
    const auto kept = static_cast<std::size_t>(std::count(keep.begin() + static_cast<std::ptrdiff_t>(s.first),
                                                          keep.begin() + static_cast<std::ptrdiff_t>(s.last), true));
    if (s.last - s.first >= min_run_samples && kept < min_run_samples)
      return s.first_run == s.last_run ? p.runs[s.first_run].label
                                       : p.runs[s.first_run].label + " to " + p.runs[s.last_run].label + " together";
  }
  return "";
}

// Places set aside in successive rounds that are one stretch of set-aside samples in a run (a ring-down's tail
// taken by the round after its peak's) are one place: merged, in the order the run passed them.
std::vector<Location> merge_contiguous(std::vector<Location> places, const std::vector<bool>& keep) {
  std::sort(places.begin(), places.end(),
            [](const Location& a, const Location& b) { return a.first_sample < b.first_sample; });
  std::vector<Location> out;
  for (Location& l : places) {
    if (!out.empty() && out.back().run == l.run) {
      Location& prev = out.back();
      const std::size_t from = std::min(prev.end_sample, l.first_sample);
      const std::size_t to = std::max(prev.end_sample, l.first_sample);
      if (std::none_of(keep.begin() + static_cast<std::ptrdiff_t>(from), keep.begin() + static_cast<std::ptrdiff_t>(to),
                       [](bool k) { return k; })) {
        if (l.end_sample > prev.end_sample) {
          prev.end_sample = l.end_sample;
          prev.where.second = l.where.second;
          prev.t_from_run_start_s.second = l.t_from_run_start_s.second;
          prev.t_machine_s.second = l.t_machine_s.second;
        }
        if (std::abs(l.peak_um) > std::abs(prev.peak_um)) prev.peak_um = l.peak_um;
        continue;
      }
    }
    out.push_back(std::move(l));
  }
  return out;
}

// Whether each place of what is left repeats in another run: judged among the places reported (those a
// partial fit's residual showed in other runs are not among them).
void repeats_among(std::vector<Mismatch>& remaining, const std::string& domain) {
  std::vector<Location*> all;
  for (auto& m : remaining)
    for (auto& l : m.locations) all.push_back(&l);
  double lo = 1e300, hi = -1e300;
  for (const Location* l : all) {
    lo = std::min({lo, l->where.first, l->where.second});
    hi = std::max({hi, l->where.first, l->where.second});
  }
  const double tol = domain == "angle_deg" ? 3.6 : 0.01 * std::max(0.0, hi - lo);
  for (Location* a : all) {
    a->repeats_in.clear();
    const auto [alo, ahi] = std::minmax(a->where.first, a->where.second);
    for (const Location* b : all) {
      if (b->run == a->run) continue;
      const auto [blo, bhi] = std::minmax(b->where.first, b->where.second);
      if (alo <= bhi + tol && blo <= ahi + tol &&
          std::find(a->repeats_in.begin(), a->repeats_in.end(), b->run) == a->repeats_in.end())
        a->repeats_in.push_back(b->run);
    }
  }
}

namespace {

// Whether every finding of `fewer` is one of `more`'s: its effect with its parameters' names (an axis, a direction).
bool findings_among(const Report& fewer, const Report& more) {
  const auto names = [](const Finding& f) {
    std::vector<std::string> out{f.effect};
    for (const ParamValue& v : f.parameters) out.push_back(v.name);
    return out;
  };
  return std::all_of(fewer.findings.begin(), fewer.findings.end(), [&](const Finding& f) {
    return std::any_of(more.findings.begin(), more.findings.end(),
                       [&](const Finding& g) { return names(g) == names(f); });
  });
}

}  // namespace

// One fault is one place: a place set aside with the others whose stretch the last pass's findings explain
// (unexplained_places) is given back, and the pass run again with the rest set aside. Kept when that pass leaves no
// new structure and finds as much, or leaves no structure and finds nothing the last did not: an effect the last found
// beside the places given back that does not hold without them held only where their offsets did its work (issue 41
// item 10: beside a slip and a backlash at 2 x 18,859 samples, a lateral play and a vibration). `aside`, `keep`,
// `after` and `last` are then its.
void release_explained(const Problem& problem, const ExplainOptions& options, double sigma,
                       std::vector<Location>& aside, std::vector<bool>& keep, std::vector<OffsetAfter>& after,
                       FittedOffsets& fitted, Pass& last) {
  const std::vector<bool> fault =
      unexplained_places(problem, last, aside, keep, fitted.offsets, sigma, options.alpha);
  const auto faults = static_cast<std::size_t>(std::count(fault.begin(), fault.end(), true));
  if (faults == 0 || faults == aside.size()) return;
  std::vector<Location> places;
  for (std::size_t k = 0; k < aside.size(); ++k)
    if (fault[k]) places.push_back(aside[k]);
  std::vector<bool> trial(keep.size(), true);
  set_aside(problem, places, trial);
  std::vector<OffsetAfter> trial_after;
  for (const auto& l : places) trial_after.push_back(offset_after(problem, l, trial));
  FittedOffsets trial_fitted;
  trial_fitted.offsets = fitted_offsets(problem, trial, trial_after, &trial_fitted.left_out);
  const Reduced reduced = without_samples(problem, trial, trial_fitted.offsets);
  if (options.on_progress)
    options.on_progress("pass with " + std::to_string(places.size()) + " of " + std::to_string(aside.size()) +
                        " places set aside (the findings explain the others)");
  Pass next = explain_once(reduced.problem, options);
  const bool fewer = next.report.findings.size() < last.report.findings.size();
  if ((next.report.unexplained && !last.report.unexplained) ||
      (fewer && (next.report.unexplained || !findings_among(next.report, last.report))))
    return;
  aside = std::move(places);
  keep = std::move(trial);
  after = std::move(trial_after);
  fitted = std::move(trial_fitted);
  last = std::move(next);
}

}  // namespace guideway::models::explain::engine
