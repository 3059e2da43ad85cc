#pragma once
// The "dbb" test session: assembles DBB circles from the dbb-can device's samples (bar length and the
// axis encoders), matches each traced circle to a pattern of the test (plane, direction, radius; the
// socket height comes from the pattern) and identifies Lai's model and the ballbar diagnostics, per
// plane, when every pattern has been traced (or on stop, with the circles traced so far). The tests
// (option test): standard (ccw + cw at h = 0 in the plane), three-plane (xy 360 deg, xz and yz 220 deg
// above the centre, ccw + cw each), lai (Lai's three patterns); or the patterns given.
//
// Segmentation needs no set-up values: a circle is a stretch of motion (encoder speed above a
// threshold) whose encoder positions fit a circle; its plane is the two axes that moved (with x, y and
// z encoders; else the plane option), its centre and radius come from the fit, its direction from the
// sign of the swept angle, and the central data arc of the swept arc is kept (360 deg, or the pattern's:
// the feed-in/feed-out overshoot arcs are dropped). dL = bar reading - sqrt(r^2 + h^2).

#include "sessions/session.hpp"

namespace guideway::sessions {

SessionKind dbb_session_kind();

}  // namespace guideway::sessions
