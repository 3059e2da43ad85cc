#pragma once
// The "runout" test session: several spindle revolutions (default 20 at 60 rpm) of an inductance
// micrometer on a thrust plate (docs/formats.md, "Run-out revolution"), assembled from the
// micrometer-modbus device's live displacement readings; identified with models/flatness run-out
// squareness (Mu Eq. 21) and ISO 230-7 error motion (total, synchronous, asynchronous), and explained
// (models/explain/runout_explain: harmonics, asynchronous lines, axial growth, speed variation).
//
// The micrometer gives no spindle angle: the spindle turns at `rpm`, so a sample's angle is
// 6 * rpm * (t - t_first) degrees from the first sample (the phase is relative; Eq. 21 needs only
// the amplitude). The session completes after `revolutions` full turns. The record is written as a
// run-out file and identified and explained from that very text, so `guideway identify runout` and
// `guideway explain --model runout` on the derived file give the same results.

#include "sessions/session.hpp"

namespace guideway::sessions {

SessionKind runout_session_kind();

}  // namespace guideway::sessions
