#pragma once
// The test-session kinds guidewayd offers (dbb, straightness, runout, profile), each implemented next
// to its model and registered here.

#include "sessions/session.hpp"

namespace guideway::sessions {

void register_builtin_sessions(SessionRegistry& registry);

}  // namespace guideway::sessions
