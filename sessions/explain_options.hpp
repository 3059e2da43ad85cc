#pragma once
// The options a session kind runs EXPLAIN with: EXPLAIN's defaults and what the daemon set on the session
// (Session::set_explain_memory_mb).

#include "models/explain/explain_result.hpp"
#include "sessions/session.hpp"

namespace guideway::sessions {

[[nodiscard]] inline models::explain::ExplainOptions explain_options(const Session& session) {
  models::explain::ExplainOptions options;
  if (const auto mb = session.explain_memory_mb()) options.memory_mb = *mb;
  return options;
}

}  // namespace guideway::sessions
