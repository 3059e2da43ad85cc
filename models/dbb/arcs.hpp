#pragma once
// What the data arcs of DBB runs hold: a partial arc (>= 180 deg) and gaps lose the reversals and the
// stretches of the circle that lie outside, and with them what tells some terms apart. Says, in words,
// which reversals of each plane axis the samples hold, what a partial arc or a gap costs, and why a term
// the fit refused could not be told apart (conventions: docs/conventions.md, "Partial arcs and gaps").
// Pure functions; thread safe.

#include <string>
#include <vector>

#include "formats/dbb_run.hpp"

namespace guideway::models::dbb {

// The reversals of one plane axis (0: a, which reverses at 0 and 180 deg; 1: b, at 90 and 270 deg) that
// some run passes (samples at least a degree either side: a gap over it still shows the lost motion's
// step), and those that no run passes (outside every arc, or at its very end).
struct AxisReversals {
  std::vector<double> seen_deg, missed_deg;  // in [0, 360)
};
AxisReversals reversals_in_arcs(const std::vector<formats::DbbRun>& runs, int axis);

// "-20.0 to 200.0 deg" per run, joined: the arcs the samples span.
std::string arcs_text(const std::vector<formats::DbbRun>& runs);

// Notes on the runs' arcs and gaps for an identification: each partial arc and what it holds of the axes'
// reversals, each gap, and that G, H and the deviations are over the data arcs. Empty for full circles
// without gaps.
std::vector<std::string> arc_notes(const std::vector<formats::DbbRun>& runs, const std::string& plane);

// Why the runs cannot separate the term `name` (a diagnostic's or Lai's name, as the fit refused it), in
// words: a reversal term of an axis none of whose reversals lies in the data arcs, else that its signature
// over the arcs is a combination of the others'.
std::string why_unidentifiable(const std::string& name, const std::vector<formats::DbbRun>& runs,
                               const std::string& plane);

}  // namespace guideway::models::dbb
