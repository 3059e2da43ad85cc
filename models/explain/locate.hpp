#pragma once
// The locate step: is a residual noise, and if not, where is it structured? Per run, a Daubechies
// (db4) decomposition gives the energy per band, tested against the noise level from the finest
// details (chi-square); the runs test and Ljung-Box test whiteness; the wavelet-denoised residual
// (universal threshold) shows the places; runs of equal geometry are compared across direction and
// feed, and the residual is regressed on time. Pure functions; thread safe.

#include <vector>

#include <Eigen/Core>

#include "models/explain/explain.hpp"

namespace guideway::models::explain {

// Shorter runs are not decomposed: their structure is not tested.
inline constexpr std::size_t min_run_samples = 32;

struct Located {
  double sigma_um = 0.0;         // noise level (MAD of the finest details)
  bool structured = false;       // any test significant at alpha
  std::vector<Mismatch> places;  // empty when not structured
  std::vector<int> flagged;      // bands with significant energy: 0 = approximation, j = detail level j
  std::vector<double> smooth;    // the flagged bands of the residual, hard-thresholded, per sample
  double visible_energy = 0.0;   // sum of smooth^2 (um^2)
};

// sigma_um > 0 imposes the noise level (e.g. the baseline's) instead of estimating it.
Located locate(const Problem& problem, const Eigen::VectorXd& residual_um, double alpha, double sigma_um = 0.0);

// Energy of the flagged bands of a residual after hard thresholding at the universal threshold (for
// the share of the located structure a candidate removes); 0 when nothing is flagged.
double visible_energy(const Problem& problem, const Eigen::VectorXd& residual_um, double sigma_um,
                      const std::vector<int>& flagged);

// [first, last) sample index of each run.
std::vector<std::pair<std::size_t, std::size_t>> run_ranges(const Problem& problem);

// The place of samples [first, end) of one run, as a Location reports it (angles wrapped to 0-360 degrees).
Location location_of(const Problem& problem, std::size_t first, std::size_t end, double peak_um);

// What the structure tests decompose, each a [first, last) sample range: every run alone, except the runs of a path
// (Problem::path_of_run) one of which is shorter than min_run_samples: those joined, in the order taken, one range.
// A range shorter than min_run_samples is not tested.
struct TestedStretch {
  std::size_t first = 0, last = 0;
  std::size_t first_run = 0, last_run = 0;  // the runs it holds, [first_run, last_run]
};
std::vector<TestedStretch> tested_stretches(const Problem& problem);

}  // namespace guideway::models::explain
