// scale_mismatch: the axes' length scales differ. In the DBB base (Lai's S_x, S_y): no candidate term.
#include "models/explain/effects/effect.hpp"

namespace guideway::models::explain::effects {

extern const Effect scale_mismatch{
    {"scale_mismatch",
     "the axes' length scales differ (pitch of screw or scale, temperature of the scale)",
     "axis position",
     "an ellipse along the axes",
     {"dbb"},
     {}},
    {},
    {}};

}  // namespace guideway::models::explain::effects
