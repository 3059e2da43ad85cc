#pragma once
// Where the ballbar diagnostics' nonlinear terms sit (models/dbb, diagnostics.hpp): each axis' reversal spike
// (its decay time and its delay after the reversal) and each axis' lead-screw period of a cyclic error, searched
// on a preliminary fit's residual and kept only when they explain clearly more than noise. Pure functions;
// thread safe.

#include <vector>

#include "formats/dbb_run.hpp"
#include "models/common/least_squares.hpp"
#include "models/dbb/diagnostics.hpp"
#include "models/dbb/fit_points.hpp"

namespace guideway::models::dbb::fitting {

// Reversal spikes: the decay time and delay of each axis that explain most of the preliminary residual.
void search_reversal_spikes(const std::vector<formats::DbbRun>& runs, const std::vector<Point>& pts,
                            const LsqResult& base, DiagLayout& L);

// Cyclic error: the given period or the best of the usual ball-screw leads (at most r/4), per axis, kept
// only when it explains clearly more than noise (2 dof, about p < 1e-6); the points get its phases.
void choose_cyclic_periods(const std::vector<formats::DbbRun>& runs, std::vector<Point>& pts, const LsqResult& base,
                           const IdentifyOptions& options, DiagLayout& L);

}  // namespace guideway::models::dbb::fitting
