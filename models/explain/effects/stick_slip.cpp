// stick_slip: friction at low speed makes an axis move in jerks just after it reverses.
#include <cmath>
#include <iterator>
#include <limits>
#include <numbers>
#include <utility>

#include "models/dbb/geometry.hpp"
#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// The grid searched, and a step past each end (Variant::beyond: a stick-slip is as physical at 2.5 Hz or 400 ms).
constexpr double frequencies_hz[] = {5.0, 10.0, 20.0};
constexpr double decays_ms[] = {50.0, 200.0};
constexpr double below_frequencies_hz = 2.5, above_frequencies_hz = 40.0;
constexpr double below_decays_ms = 25.0, above_decays_ms = 400.0;

// A decaying oscillation of the axis after it reverses (low speed near the reversal), starting against the
// new direction of motion as the reversal spike does.
Variant stick_slip_variant(const DbbTerms& t, double f_hz, double tau_ms) {
  const double tau = tau_ms * 1e-3;
  Variant v = make_lazy_variant(
      t.geo, {results::name(results::stick_slip, t.plane, 0), results::name(results::stick_slip, t.plane, 1)},
      [=](const Geo& p, double* o) {
        o[0] = p.lambda * p.c * (-p.sgn_a) * dbb::reversal_spike_decay(p.since_a_s, tau) *
               std::sin(2 * pi * f_hz * p.since_a_s);
        o[1] = p.lambda * p.s * (-p.sgn_b) * dbb::reversal_spike_decay(p.since_b_s, tau) *
               std::sin(2 * pi * f_hz * p.since_b_s);
      });
  v.fixed.push_back({results::name(results::stick_slip_frequency), f_hz, std::numeric_limits<double>::quiet_NaN()});
  v.fixed.push_back({results::name(results::stick_slip_decay), tau_ms, std::numeric_limits<double>::quiet_NaN()});
  v.searched = 2;
  return v;
}

// Frequency and decay searched on the grid; at each end, the variant a step past it.
bool stick_slip_dbb_term(const DbbTerms& t, Candidate& c) {
  for (const double f_hz : frequencies_hz) {
    for (const double tau_ms : decays_ms) {
      Variant v = stick_slip_variant(t, f_hz, tau_ms);
      if (f_hz == frequencies_hz[0]) v.beyond.push_back(stick_slip_variant(t, below_frequencies_hz, tau_ms));
      if (f_hz == std::end(frequencies_hz)[-1]) v.beyond.push_back(stick_slip_variant(t, above_frequencies_hz, tau_ms));
      if (tau_ms == decays_ms[0]) v.beyond.push_back(stick_slip_variant(t, f_hz, below_decays_ms));
      if (tau_ms == std::end(decays_ms)[-1]) v.beyond.push_back(stick_slip_variant(t, f_hz, above_decays_ms));
      c.variants.push_back(std::move(v));
    }
  }
  return true;
}

}  // namespace

extern const Effect stick_slip{
    {"stick_slip",
     "friction at low speed: the axis moves in jerks near a reversal where its velocity is small",
     "velocity (near reversals)",
     "a decaying oscillation after each reversal of the axis",
     {},
     {"dbb"}},
    {"friction at low speed makes an axis move in jerks just after it reverses, a decaying oscillation",
     &stick_slip_dbb_term},
    {},
    true};

}  // namespace guideway::models::explain::effects
