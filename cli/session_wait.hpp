#pragma once
// Waiting for a session the CLI started (`guideway start --wait`, `guideway map sequence --run`): the session's
// state, progress and time left on standard error while it runs, then its PARAMS or its failure.

#include <string>

#include <nlohmann/json.hpp>

#include "cli/daemon_client.hpp"

namespace guideway::cli {

// Asks the daemon to send PARAMS, EVENT and STATUS messages on this connection (before the session starts).
void watch_session_progress(DaemonClient& c);

// The session's PARAMS (printed with print_params unless `json`: then as the daemon's JSON; `print` false:
// not printed) within timeout_s; throws std::runtime_error when it fails or does not finish in time.
nlohmann::json wait_for_params(DaemonClient& c, const std::string& session, double timeout_s, bool quiet, bool json,
                               bool print = true);

}  // namespace guideway::cli
