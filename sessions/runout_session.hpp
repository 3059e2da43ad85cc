#pragma once
// The "runout" test session: one (or more) spindle revolutions of an inductance micrometer on a
// thrust plate (docs/formats.md, "Run-out revolution"), assembled from the micrometer-modbus device's
// live displacement readings and identified with models/flatness run-out squareness (Mu Eq. 21).
//
// The micrometer gives no spindle angle: the spindle turns at `rpm`, so a sample's angle is
// 6 * rpm * (t - t_first) degrees from the first sample (the phase is relative; Eq. 21 needs only
// the amplitude). The session completes after `revolutions` full turns. The revolution is written
// as a run-out file and identified from that very text, so `guideway identify runout` on the derived
// file gives the same result.

#include "sessions/session.hpp"

namespace guideway::sessions {

SessionKind runout_session_kind();

}  // namespace guideway::sessions
