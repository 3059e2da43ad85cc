#pragma once
// Logger for guidewayd: to the journal when systemd started us (JOURNAL_STREAM names our stderr),
// to the terminal otherwise.

#include <memory>
#include <string>

#include <spdlog/spdlog.h>

namespace guideway::daemon {

std::shared_ptr<spdlog::logger> make_logger(const std::string& level);
bool stderr_is_journal();

}  // namespace guideway::daemon
