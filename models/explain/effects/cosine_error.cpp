// cosine_error: the measuring line is tilted to the motion. In the DBB base (part of the scale): no term.
#include "models/explain/effects/effect.hpp"

namespace guideway::models::explain::effects {

extern const Effect cosine_error{
    {"cosine_error",
     "the measuring line is tilted to the motion, so the reading is shortened by the cosine",
     "axis position",
     "a length error proportional to the travel (DBB: part of the scale)",
     {"dbb"},
     {}},
    {},
    {}};

}  // namespace guideway::models::explain::effects
