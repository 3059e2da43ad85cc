#include "daemon/session_kinds.hpp"

#include "daemon/dbb_session.hpp"

namespace guideway::daemon {

void register_builtin_sessions(SessionRegistry& registry) {
  registry.add(dbb_session_kind());
}

}  // namespace guideway::daemon
