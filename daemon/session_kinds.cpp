#include "daemon/session_kinds.hpp"

#include "daemon/dbb_session.hpp"
#include "daemon/profile_session.hpp"
#include "daemon/runout_session.hpp"
#include "daemon/straightness_session.hpp"

namespace guideway::daemon {

void register_builtin_sessions(SessionRegistry& registry) {
  registry.add(dbb_session_kind());
  registry.add(straightness_session_kind());
  registry.add(runout_session_kind());
  registry.add(profile_session_kind());
}

}  // namespace guideway::daemon
