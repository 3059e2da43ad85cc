// What the effects' DBB terms are built from (dbb_terms.hpp): the runs' per-sample geometry, the drives' lagging
// motion.
#include "models/explain/effects/dbb_terms.hpp"

namespace guideway::models::explain::effects {

std::shared_ptr<const std::vector<dbb::DriveTrack>> drive_tracks(const std::vector<Geo>& g,
                                                                 const std::vector<double>& delays) {
  return std::make_shared<const std::vector<dbb::DriveTrack>>(dbb::drive_tracks(g, delays));
}

}  // namespace guideway::models::explain::effects
