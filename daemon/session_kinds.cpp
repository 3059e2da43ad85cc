#include "daemon/session_kinds.hpp"

namespace guideway::daemon {

void register_builtin_sessions(SessionRegistry& registry) {
  (void)registry;  // session kinds register here as their models land (one line each)
}

}  // namespace guideway::daemon
