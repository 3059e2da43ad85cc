#pragma once
// The ballbar diagnostics a user expects of DBB runs (models/dbb, identify.hpp): centre offset per run, scales,
// squareness, backlash, lateral play, servo mismatch, straightness, reversal spikes and cyclic errors fitted
// together to the in-plane runs (h = 0), with their parts of the circular deviation. Pure functions; thread safe.

#include <cstddef>
#include <string>
#include <vector>

#include "formats/dbb_run.hpp"
#include "models/dbb/fit_points.hpp"
#include "models/dbb/identify.hpp"
#include "models/dbb/lai_fit.hpp"

namespace guideway::models::dbb::fitting {

// The columns of one diagnostics fit: per run its centre offset, then the global terms, then the optional ones.
struct DiagLayout {
  std::size_t runs = 0;
  bool spikes = false;
  // Gauss-Newton columns for the decay times, when a spike is clearly present (amp_* = its height
  // from the search, um): the decay and the height are then fitted together with their covariance.
  bool decay_a = false, decay_b = false;
  double amp_a = 0, amp_b = 0;
  bool cyclic_a = false, cyclic_b = false;
  double tau_a = assumed_spike_decay_s, tau_b = assumed_spike_decay_s, delay_a = 0, delay_b = 0, period_a = 0,
         period_b = 0;
  const BesideColumns* beside = nullptr;  // fitted beside, after every diagnostic (may be null)
  [[nodiscard]] std::size_t beside_count() const { return beside ? beside->size() : 0; }
  [[nodiscard]] std::size_t global0() const { return 2 * runs; }
  // global parameters after the per-run centre offsets
  enum G {
    scale_a,
    scale_b,
    squareness,
    backlash_a,
    backlash_b,
    play_a,
    play_b,
    servo,
    bow_a,
    bow_b,
    cubic,  // the difference of the axes' cubic straightness, all a circle sees of them besides a squareness
    n_base
  };
  [[nodiscard]] std::size_t count() const {
    return global0() + n_base + (spikes ? 2 : 0) + (decay_a ? 1 : 0) + (decay_b ? 1 : 0) + (cyclic_a ? 2 : 0) +
           (cyclic_b ? 2 : 0) + beside_count();
  }
  [[nodiscard]] std::size_t spike0() const { return global0() + n_base; }
  [[nodiscard]] std::size_t decay_a0() const { return spike0() + (spikes ? 2 : 0); }
  [[nodiscard]] std::size_t decay_b0() const { return decay_a0() + (decay_a ? 1 : 0); }
  [[nodiscard]] std::size_t cyc_a0() const { return decay_b0() + (decay_b ? 1 : 0); }
  [[nodiscard]] std::size_t cyc_b0() const { return cyc_a0() + (cyclic_a ? 2 : 0); }
  [[nodiscard]] std::size_t beside0() const { return cyc_b0() + (cyclic_b ? 2 : 0); }
};

// Columns of the widest diagnostics fit less the per-run centres and the terms fitted beside (every optional
// term: spikes 2, decays 2, cyclic 4).
inline constexpr std::size_t diagnostics_max_columns = DiagLayout::n_base + 8;

// The ballbar diagnostics, of the runs whose geometry they model (an in-plane bar, h = 0), with the
// deadband shape Lai's fit estimated. Fills out.diagnostics, out.notes and out.ranking; returns each
// run's residual RMS (NaN for the runs the diagnostics do not model). Throws FitError when a fit cannot be
// solved.
std::vector<double> diagnose_in_plane_runs(const std::vector<formats::DbbRun>& runs, const std::string& plane,
                                           FitWork& work, const LaiFit& lai, const IdentifyOptions& options,
                                           Identification& out);

}  // namespace guideway::models::dbb::fitting
