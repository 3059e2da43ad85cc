// servo_mismatch: the two axes' position loops lag by different times.
#include "models/explain/effects/dbb_terms.hpp"
#include "models/explain/effects/effect.hpp"
#include "results/parameters.hpp"

namespace guideway::models::explain::effects {

namespace {

bool servo_mismatch_dbb_term(const DbbTerms& t, Candidate& c) {
  c.variants.push_back(make_lazy_variant(t.geo, {results::name(results::servo_mismatch)}, [](const Geo& p, double* o) {
    o[0] = p.lambda * p.dir * p.feed_m_per_s * p.s * p.c * 1e3;  // 1 ms of lag difference; v in m/s -> um
  }));
  return true;
}

}  // namespace

extern const Effect servo_mismatch{
    {"servo_mismatch",
     "the two axes' position loops lag by different times (different gains)",
     "direction and feed",
     "an oval along a diagonal that flips sign with direction and grows with feed",
     {},
     {"dbb"}},
    {"the two axes' position loops lag by different times, so the circle is stretched along a diagonal by an amount "
     "that grows with feed and flips with direction",
     &servo_mismatch_dbb_term},
    {}};

}  // namespace guideway::models::explain::effects
