// Renders a session's report with report/ (session_report.hpp).
#include "daemon/reports/session_report.hpp"

#include "models/explain/dbb_checked.hpp"
#include "report/report.hpp"

namespace guideway::daemon {

std::string render_session_report(const SessionReportRequest& request) {
  report::ReportOptions options;
  options.title = request.title;
  options.subtitle = request.subtitle;
  if (!request.instrument.empty()) options.instruments.push_back({request.device, request.instrument});
  options.instruments_checked_on = request.checked_on;
  // What PARAMS published, not identified again from the files.
  if (request.session != nullptr) {
    if (const auto* identified = request.session->identified_planes()) options.identified = *identified;
  }
  return report::render_report(request.inputs, options);
}

}  // namespace guideway::daemon
