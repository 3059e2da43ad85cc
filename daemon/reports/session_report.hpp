#pragma once
// A finished session's HTML report as guidewayd renders it: report/'s page over the session's files, with
// what the session identified (its PARAMS) instead of identifying the files again. Given to the daemon as
// its DaemonOptions::session_report.

#include <string>

#include "daemon/session_manager.hpp"

namespace guideway::daemon {

[[nodiscard]] std::string render_session_report(const SessionReportRequest& request);

}  // namespace guideway::daemon
