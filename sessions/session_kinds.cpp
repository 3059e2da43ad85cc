// The session kinds guidewayd offers, one registration line each (session_kinds.hpp).
#include "sessions/session_kinds.hpp"

#include "sessions/dbb_session.hpp"
#include "sessions/profile_session.hpp"
#include "sessions/runout_session.hpp"
#include "sessions/straightness_session.hpp"

namespace guideway::sessions {

void register_builtin_sessions(SessionRegistry& registry) {
  registry.add(dbb_session_kind());
  registry.add(straightness_session_kind());
  registry.add(runout_session_kind());
  registry.add(profile_session_kind());
}

}  // namespace guideway::sessions
