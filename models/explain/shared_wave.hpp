#pragma once
// A pitch wave in the geometry a traverse's passes share (docs/explain.md "A wave the passes share"): where the base
// is a term per station, a wave every pass reads at the same stations is geometry, and the passes' disagreement,
// which the engine's tests judge, holds nothing of it. It is judged against the geometry itself: the strongest line
// of the station means' periodogram over the geometry's own spectrum there (a smooth power law fitted to that
// periodogram) and over its neighbours' median, and fitted, its size and u with that spectrum as the noise. Pure
// function; thread safe.

#include <cstddef>
#include <vector>

namespace guideway::models::explain {

struct SharedWave {
  bool judged = false;       // the band holds enough lines to fit the spectrum (shared_wave_min_lines)
  bool found = false;        // ratio and local_ratio > needed
  double cycles = 0.0;       // the line, in cycles over the stations (placed between the periodogram's bins)
  double period_m = 0.0;     // stations x step / cycles
  double ratio = 0.0;        // the line's periodogram over the geometry's spectrum there
  double local_ratio = 0.0;  // over its neighbours' (the median of the lines within a quarter of its cycles, 4 at
                             // least, each side, but the next: the spectrum's fit can miss a steep or bent stretch)
  double needed = 0.0;       // ln(lines / alpha): an exponential's tail, Bonferroni over the lines searched
  std::size_t lines = 0;     // the lines searched: 4 per resolution, over the band
  double spectrum = 0.0;     // the geometry's spectrum at the line (urad^2, a station mean's variance there)
  double sin_arcsec = 0.0;   // A cos(phi): the wave A sin(2 pi x / P + phi) at the stations' mid-points x
  double cos_arcsec = 0.0;   // A sin(phi)
  double var_sin = 0.0, var_cos = 0.0, cov_sin_cos = 0.0;  // arcsec^2, with the spectrum as the noise
};

// The lines searched start at this many cycles over the stations (a longer wave is the figure's, which the
// polynomial of the geometry holds) and end at 2.5 stations a cycle (pitch_wave's band); the spectrum is fitted over
// them when there are at least shared_wave_min_lines.
inline constexpr double shared_wave_first_cycles = 3.0;
inline constexpr std::size_t shared_wave_min_lines = 16;

// mean_urad: the passes' mean reading at each station s, whose mid-point is x0_m + (s + 1/2) step_m.
SharedWave shared_wave(const std::vector<double>& mean_urad, double x0_m, double step_m, double alpha);

}  // namespace guideway::models::explain
