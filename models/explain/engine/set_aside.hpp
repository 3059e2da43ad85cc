#pragma once
// EXPLAIN's set-aside rounds (models/explain/engine, docs/explain.md step 5): when the residual left is
// structured at a few places no effect explains (a step, a transient, a burst), those places are set aside,
// the reading free to stand off by a constant after each, and the effects sought again in the rest; a place
// the later findings explain is given back. Pure functions; thread safe.

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "models/explain/engine/explain_pass.hpp"
#include "models/explain/explain.hpp"

namespace guideway::models::explain::engine {

// Per place set aside: its run and the first sample after it (where the reading may stand off). The nuisance columns
// fitted_offsets makes of the places are of the same form: the reading's step from that sample on, in the place's run
// and every later one; or, with `later_runs` for the sample, the level of the runs after the place's, apart: a ball
// that slips may stay slipped in the runs after (the scenario suite's) or be seated again between runs (issue 41 item
// 10: the step alone left the second run's level to a ccw/cw effect, lateral play X -0.93 / Y +0.94 um on a machine
// with none).
using OffsetAfter = std::pair<std::size_t, std::size_t>;
inline constexpr std::size_t later_runs = static_cast<std::size_t>(-1);
// Whether the sample is in a nuisance column's reach: from a place's first sample after it on, in its run and every
// later one, or (with later_runs) in the runs after it alone, the reading may stand off by a constant (a step, such
// as a ball slipping in its socket, leaves the data after it offset from the data before it, whatever is set aside).
bool stands_off(const Problem& p, OffsetAfter after, std::size_t sample);

// The problem without the samples `keep` leaves out: the base's and every listed variant's rows dropped,
// each generator given the whole residual (zero on the rows left out) with those rows out of use, its
// variants' rows dropped; a contribution measured on the whole sample grid (a left-out sample takes its
// run's nearest kept value). `after`: the nuisance columns (fitted_offsets), each a constant the reading may stand
// off by (from a place's sample after it on, or in the runs after it alone), in the base. Every variant's block over
// all samples is its Variant::all_samples.
struct Reduced {
  Problem problem;
  std::vector<Eigen::Index> kept;  // the whole problem's index of each sample
};
Reduced without_samples(const Problem& p, const std::vector<bool>& keep, const std::vector<OffsetAfter>& after);

// Where a pass left structure no effect explains, place by place, in the whole problem's samples
// (`index`: the whole problem's index of each sample of the pass's problem): the places of its remaining
// structure, or when that is structured throughout, those of the probe (Pass::probe).
std::vector<Location> remaining_places(const Pass& pass, const std::vector<Eigen::Index>& index, bool& from_probe);
// The strongest place of the pass's probe (Pass::probe), in the whole problem's samples; none when it has none.
std::vector<Location> strongest_probe_place(const Pass& pass, const std::vector<Eigen::Index>& index);

// Sets aside each place's stretch (the place and a margin on either side). Returns the samples set aside in all.
std::size_t set_aside(const Problem& p, const std::vector<Location>& places, std::vector<bool>& keep);

// A place's run and the first sample after the stretch set aside about it (or its run's end).
OffsetAfter offset_after(const Problem& p, const Location& l, const std::vector<bool>& keep);

// The base's name of the reading's offset after a place set aside (without_samples), before its number.
inline constexpr const char* offset_after_set_aside_prefix = "offset_after_set_aside_";

// The nuisance columns of the places `after` (per place, the step after it; per run with a place, the level of the
// runs after it, apart; none the samples kept leave empty or the same as another) that may be fitted: not one that
// takes a candidate's column. On the samples kept, the step after a place at a run's end (a traverse's turnaround) is
// with the base the level of the later runs, a reflector rocking's own column, which no test could then tell from the
// offset, and the candidate could not be fitted at all. A column is left out when, with it, less than 1/32 of a listed variant's column beyond the
// base is left beyond the offsets (a fold could then hold out all that is left); the fewest left out, most taken
// first. `notes`, when given, gets one line per column left out: its place and the candidate whose column it takes.
std::vector<OffsetAfter> fitted_offsets(const Problem& p, const std::vector<bool>& keep,
                                        const std::vector<OffsetAfter>& after,
                                        std::vector<std::string>* notes = nullptr);

// fitted_offsets of a pass's `after` on its samples kept, and its notes: made once per pass (fitted_offsets makes
// every listed variant over every sample), read by the pass, release_explained and the report's notes.
struct FittedOffsets {
  std::vector<OffsetAfter> offsets;
  std::vector<std::string> left_out;
};

// A run the structure tests could look at that setting aside would leave too short for them (a traverse's
// pass of 33 readings; short passes tested together, locate.hpp tested_stretches: those passes): its label, or ""
// when there is none.
std::string starved_run(const Problem& p, const std::vector<bool>& keep);

// One fault is one place: a place set aside with the others whose stretch the last pass's findings explain
// is given back, and the pass run again with the rest set aside. Kept when that pass leaves no new structure and
// finds as much, or leaves no structure and finds nothing the last did not (what the last found beside the places
// given back held only where their offsets did its work); `aside`, `keep`, `after`, `fitted` (the offsets of `after` fitted on `keep`) and `last` are
// then its.
void release_explained(const Problem& problem, const ExplainOptions& options, double sigma,
                       std::vector<Location>& aside, std::vector<bool>& keep, std::vector<OffsetAfter>& after,
                       FittedOffsets& fitted, Pass& last);

// Places set aside in successive rounds that are one stretch of set-aside samples in a run are one place:
// merged, in the order the run passed them.
std::vector<Location> merge_contiguous(std::vector<Location> places, const std::vector<bool>& keep);

// Whether each place of what is left repeats in another run: judged among the places reported.
void repeats_among(std::vector<Mismatch>& remaining, const std::string& domain);

}  // namespace guideway::models::explain::engine
