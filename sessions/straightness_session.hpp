#pragma once
// The "straightness" test session: an autocollimator traverse (docs/formats.md, "Straightness
// traverse") assembled from the autocollimator-serial device's live readings, identified with
// models/flatness straightness-from-angles.
//
// Stations need no position input: the reflector rests on a station for a while (a dwell: valid
// readings that stay within `settle_arcsec` of their mean for at least `min_dwell_s`) and is moved
// between stations (the readings jump, or the beam is lost while it is lifted). One station reading
// is the mean over its dwell. A beam break of at least `return_gap_s` is the reflector being carried
// back to the start: by default the traverse begins after one (so a session started in the middle of
// a traverse waits for the next), and, unless `stations` fixes the count, the next one ends it.
// The traverse program runs `passes` passes over the same stations (default 2: forward, then back, the
// turn station read twice), so the stations taken are passes x stations per pass; a pass is identified
// with its direction from its place in that order. The station readings are written as a traverse file
// (with each reading's time and pass) and identified from that very text, the first pass, so
// `guideway identify straightness` on the derived file gives the same result; EXPLAIN is
// `guideway explain --model traverse` of that text.

#include "sessions/session.hpp"

namespace guideway::sessions {

SessionKind straightness_session_kind();

}  // namespace guideway::sessions
