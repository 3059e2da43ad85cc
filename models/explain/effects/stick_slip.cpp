// stick_slip: friction at low speed makes an axis move in jerks just after it reverses.
#include <cmath>
#include <limits>
#include <numbers>

#include "models/dbb/geometry.hpp"
#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// A decaying oscillation of the axis after it reverses (low speed near the reversal), starting against the
// new direction of motion as the reversal spike does; frequency and decay searched on a grid.
bool stick_slip_dbb_term(const DbbTerms& t, Candidate& c) {
  for (double f_hz : {5.0, 10.0, 20.0}) {
    for (double tau_ms : {50.0, 200.0}) {
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
