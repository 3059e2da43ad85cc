// straightness: the guideway is not straight. In every base model: no candidate term.
#include "models/explain/effects/effect.hpp"

namespace guideway::models::explain::effects {

extern const Effect straightness{{"straightness",
                                  "the guideway is not straight",
                                  "axis position",
                                  "a smooth curve in axis position, the same in every run",
                                  {"dbb", "flatness", "straightness"},
                                  {}},
                                 {},
                                 {}};

}  // namespace guideway::models::explain::effects
