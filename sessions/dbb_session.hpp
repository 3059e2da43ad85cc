#pragma once
// The "dbb" test session: assembles DBB circles from the dbb-can device's samples (bar length and the
// two axis encoders), matches each traced circle to a pattern of the test (radius, direction; the
// socket height comes from the pattern list), and identifies Lai's model and the ballbar diagnostics
// when every pattern has been traced (or on stop, with the circles traced so far).
//
// Segmentation needs no set-up values: a circle is a stretch of motion (encoder speed above a
// threshold) whose encoder positions fit a circle; its centre and radius come from that fit, its
// direction from the sign of the swept angle, and the central 360 deg of the swept arc is kept (the
// feed-in/feed-out overshoot arcs are dropped). dL = bar reading - sqrt(r^2 + h^2).

#include "sessions/session.hpp"

namespace guideway::sessions {

SessionKind dbb_session_kind();

}  // namespace guideway::sessions
