// reversal_spike: stiction at the axis reversals, a spike decaying in milliseconds.
#include <iterator>
#include <limits>
#include <utility>

#include "models/dbb/geometry.hpp"
#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

// The decays searched (ms). Below 2 ms a spike is one sample at any rate a ballbar samples (a bound of what the
// data resolve, not a grid's edge); above 100 ms it is tried a step past (Variant::beyond): a slower decay is as
// physical, and a spike found at the grid's end may be a slower shape's best stand-in.
constexpr double spike_decays_ms[] = {2.0, 5.0, 10.0, 20.0, 50.0, 100.0};
constexpr double spike_decay_past_ms = 200.0;

Variant reversal_spike_variant(const DbbTerms& t, double tau_ms) {
  const double tau = tau_ms * 1e-3;
  Variant v = make_lazy_variant(
      t.geo, {results::name(results::reversal_spike, t.plane, 0), results::name(results::reversal_spike, t.plane, 1)},
      [tau](const Geo& p, double* o) {
        o[0] = p.lambda * p.c * (-p.sgn_a) * dbb::reversal_spike_decay(p.since_a_s, tau);
        o[1] = p.lambda * p.s * (-p.sgn_b) * dbb::reversal_spike_decay(p.since_b_s, tau);
      });
  v.fixed.push_back({results::name(results::spike_decay), tau_ms, std::numeric_limits<double>::quiet_NaN()});
  v.searched = 1;
  return v;
}

bool reversal_spike_dbb_term(const DbbTerms& t, Candidate& c) {
  for (const double tau_ms : spike_decays_ms) {
    Variant v = reversal_spike_variant(t, tau_ms);
    if (tau_ms == spike_decays_ms[std::size(spike_decays_ms) - 1])
      v.beyond.push_back(reversal_spike_variant(t, spike_decay_past_ms));
    c.variants.push_back(std::move(v));
  }
  return true;
}

}  // namespace

extern const Effect reversal_spike{
    {"reversal_spike",
     "stiction at a reversal: the axis sticks, then the servo catches up with a decay",
     "time after a reversal",
     "a short outward spike right after each reversal, decaying in milliseconds",
     {},
     {"dbb"}},
    {"stiction at the axis reversals: the axis sticks and the servo catches up with a short decay",
     &reversal_spike_dbb_term},
    {},
    true};

}  // namespace guideway::models::explain::effects
