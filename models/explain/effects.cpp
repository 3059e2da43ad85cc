#include "models/explain/effects.hpp"

#include <stdexcept>

namespace guideway::models::explain {

const std::vector<EffectInfo>& effect_library() {
  static const std::vector<EffectInfo> lib = {
      {"backlash", "lost motion in the drive: the axis stays behind the command by half the play, on the side it came from",
       "reversal of an axis", "a step of the play at each reversal of the axis, opposite on the two sides of the circle",
       {}, {"dbb"}},
      {"reversal_spike", "stiction at a reversal: the axis sticks, then the servo catches up with a decay",
       "time after a reversal", "a short outward spike right after each reversal, decaying in milliseconds", {},
       {"dbb"}},
      {"lateral_play", "the carriage shifts sideways in its guideway when the direction of travel changes",
       "direction of travel", "a step along the other axis at each reversal of the carriage's axis", {}, {"dbb"}},
      {"servo_mismatch", "the two axes' position loops lag by different times (different gains)",
       "direction and feed", "an oval along a diagonal that flips sign with direction and grows with feed", {},
       {"dbb"}},
      {"servo_lag", "both drives follow the command late by their position loop's time constant (1/Kv)",
       "direction and feed",
       "where a run's angles are the commanded ones, every position-dependent error is seen where the drives were, "
       "a lag times the feed earlier along the path: the base's shape shifted by an angle that flips with direction "
       "and grows with feed",
       {}, {"dbb"}},
      {"cyclic_error", "lead-screw or encoder pitch error repeating every lead of the screw",
       "axis position", "a sinusoid in axis position with the screw lead as period, the same in every run", {},
       {"dbb", "flatness", "straightness"}},
      {"thermal_drift", "warm-up growth of the machine or the instrument with time",
       "time", "a trend in time that maps onto position differently at each feed and start time", {},
       {"dbb", "flatness", "straightness"}},
      {"vibration", "a structural or drive vibration at a fixed frequency", "time",
       "a sinusoid in time, unrelated to the position", {}, {"dbb"}},
      {"stick_slip", "friction at low speed: the axis moves in jerks near a reversal where its velocity is small",
       "velocity (near reversals)", "a decaying oscillation after each reversal of the axis", {}, {"dbb"}},
      {"scale_mismatch", "the axes' length scales differ (pitch of screw or scale, temperature of the scale)",
       "axis position", "an ellipse along the axes", {"dbb"}, {}},
      {"squareness", "the axes are not perpendicular", "axis position",
       "an ellipse along the diagonal (DBB) or a slope of the faced profile, the same for every direction and feed",
       {"dbb", "flatness", "straightness"}, {}},
      {"straightness", "the guideway is not straight", "axis position",
       "a smooth curve in axis position, the same in every run", {"dbb", "flatness", "straightness"}, {}},
      {"spindle_axial_runout", "the spindle moves axially twice per revolution (bearing waviness)",
       "spindle angle (time)", "a sinusoid at twice the spindle frequency on a faced surface", {},
       {"flatness", "straightness"}},
      {"tool_wear", "the tool wears with the length of cut, so the depth of cut decreases",
       "cut length", "a trend in the length cut so far (quadratic in the radius on a faced surface)", {},
       {"flatness", "straightness"}},
      {"feed_marks", "the round tool nose leaves a cusp every feed per revolution", "position",
       "a periodic profile with the feed per revolution as period", {}, {"flatness", "straightness"}},
      // Only where an angle is measured: without one, an angle curve times a constant offset is just
      // another translation curve, which the straightness polynomials of the dbb and straightness bases
      // (and Lai's roll term c0..c2) already absorb -- naming it there would be a guess.
      {"abbe_offset", "an angular error acts through an offset between the measuring line and the point of interest",
       "axis position", "the measured angle curve times the offset: on a faced part the X carriage's pitch (traverse, "
       "--straightness) times the tool's x offset, Mu Eq. 14; only the pitch's curvature separates it from "
       "squareness. No term without a measured angle (dbb, straightness: it is part of their straightness base)",
       {}, {"flatness"}},
      {"cosine_error", "the measuring line is tilted to the motion, so the reading is shortened by the cosine",
       "axis position", "a length error proportional to the travel (DBB: part of the scale)", {"dbb"}, {}},
      {"sensor_nonlinearity", "the transducer's characteristic is not linear over its range",
       "reading", "an error that is a polynomial in the reading itself, wherever it occurs", {},
       {"dbb", "flatness", "straightness"}},
  };
  return lib;
}

const EffectInfo& effect_info(std::string_view name) {
  for (const auto& e : effect_library())
    if (e.name == name) return e;
  throw std::out_of_range("unknown effect: " + std::string(name));
}

}  // namespace guideway::models::explain
