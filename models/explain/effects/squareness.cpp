// squareness: the axes are not perpendicular. In every base model: no candidate term.
#include "models/explain/effects/effect.hpp"

namespace guideway::models::explain::effects {

extern const Effect squareness{
    {"squareness",
     "the axes are not perpendicular",
     "axis position",
     "an ellipse along the diagonal (DBB) or a slope of the faced profile, the same for every direction and feed",
     {"dbb", "flatness", "straightness"},
     {}},
    {},
    {}};

}  // namespace guideway::models::explain::effects
