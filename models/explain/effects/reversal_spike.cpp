// reversal_spike: stiction at the axis reversals, a spike decaying in milliseconds.
#include <limits>

#include "models/dbb/geometry.hpp"
#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

bool reversal_spike_dbb_term(const DbbTerms& t, Candidate& c) {
  for (double tau_ms : {2.0, 5.0, 10.0, 20.0, 50.0, 100.0}) {
    const double tau = tau_ms * 1e-3;
    Variant v = make_lazy_variant(
        t.geo, {results::name(results::reversal_spike, t.plane, 0), results::name(results::reversal_spike, t.plane, 1)},
        [tau](const Geo& p, double* o) {
          o[0] = p.lambda * p.c * (-p.sgn_a) * dbb::reversal_spike_decay(p.since_a_s, tau);
          o[1] = p.lambda * p.s * (-p.sgn_b) * dbb::reversal_spike_decay(p.since_b_s, tau);
        });
    v.fixed.push_back({results::name(results::spike_decay), tau_ms, std::numeric_limits<double>::quiet_NaN()});
    v.searched = 1;
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
