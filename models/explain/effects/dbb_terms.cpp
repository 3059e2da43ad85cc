// What the effects' DBB terms are built from (dbb_terms.hpp): the runs' per-sample geometry, the drives' lagging
// motion.
#include "models/explain/effects/dbb_terms.hpp"

#include <limits>

namespace guideway::models::explain::effects {

std::shared_ptr<const std::vector<dbb::DriveTrack>> drive_tracks(const std::vector<Geo>& g,
                                                                 const std::vector<double>& delays) {
  return std::make_shared<const std::vector<dbb::DriveTrack>>(dbb::drive_tracks(g, delays));
}

double delay_past_grid_s(const std::vector<dbb::DriveTrack>& tracks) {
  if (tracks.size() < 2) return std::numeric_limits<double>::quiet_NaN();
  const double last = tracks.back().delay_s, before = tracks[tracks.size() - 2].delay_s;
  return last + (last - before);
}

}  // namespace guideway::models::explain::effects
