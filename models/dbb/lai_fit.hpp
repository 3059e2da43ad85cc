#pragma once
// Lai, Liao and Chieng's third-order guideway model fitted to DBB runs (models/dbb, identify.hpp): its
// characteristic functions (one column per Lai parameter, Table 3's names), the fit on every run with the
// deadband shape of its own backlash, and its terms' parts of the circular deviation. Pure functions; thread
// safe.

#include <cstddef>
#include <vector>

#include "formats/dbb_run.hpp"
#include "models/dbb/fit_points.hpp"
#include "models/dbb/geometry.hpp"
#include "models/dbb/identify.hpp"

namespace guideway::models::dbb::fitting {

// Columns of Lai's model with one shared centre offset (with per-run centres: 2 per run instead of 2).
std::size_t lai_column_count();

// What Lai's fit leaves for the rest of identify().
struct LaiFit {
  std::vector<double> residual_rms;   // per run
  std::vector<Contribution> ranking;  // its terms' parts of G, largest first
  Deadband shaped;                    // the deadband whose shape the points carry (widths and the drives' delay)
};

// Lai's third-order model on every run (two passes: the first only estimates the backlash whose
// deadband shape, at the drives' delay that fits best, the second uses; `pts` keep that shape). Fills
// out.fit, out.lai3 and out.beside; throws FitError when a fit cannot be solved.
LaiFit fit_lai(const std::vector<formats::DbbRun>& runs, std::vector<Point>& pts, const std::vector<DriveTrack>& tracks,
               FitWork& work, const IdentifyOptions& options, Identification& out);

}  // namespace guideway::models::dbb::fitting
