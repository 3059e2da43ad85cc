// guidewayd's logger (logging.hpp): to the journal under systemd, else to stderr.
#include "daemon/logging.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/sinks/systemd_sink.h>

namespace guideway::daemon {

bool stderr_is_journal() {
  const char* env = std::getenv("JOURNAL_STREAM");
  if (!env) return false;
  struct stat st {};
  if (fstat(STDERR_FILENO, &st) != 0) return false;
  const std::string expected = std::to_string(st.st_dev) + ":" + std::to_string(st.st_ino);
  return expected == env;
}

std::shared_ptr<spdlog::logger> make_logger(const std::string& level) {
  std::shared_ptr<spdlog::logger> logger;
  if (stderr_is_journal()) {
    logger = std::make_shared<spdlog::logger>("guidewayd", std::make_shared<spdlog::sinks::systemd_sink_mt>("guidewayd"));
    logger->set_pattern("%v");  // the journal adds time, host and priority
  } else {
    logger = std::make_shared<spdlog::logger>("guidewayd", std::make_shared<spdlog::sinks::stderr_color_sink_mt>());
    logger->set_pattern("%Y-%m-%d %H:%M:%S.%e %^%-5l%$ %v");
  }
  logger->set_level(spdlog::level::from_str(level));
  logger->flush_on(spdlog::level::warn);
  return logger;
}

bool RepeatLimiter::allow(const std::string& reason, std::int64_t now_ns, std::uint64_t& suppressed) {
  auto it = seen_.find(reason);
  if (it == seen_.end()) {
    if (seen_.size() >= 256) seen_.clear();  // bounded: the reasons a client can cause are few
    seen_[reason] = {now_ns, 0};
    suppressed = 0;
    return true;
  }
  if (now_ns - it->second.logged_ns < period_ns_) {
    ++it->second.suppressed;
    return false;
  }
  suppressed = it->second.suppressed;
  it->second = {now_ns, 0};
  return true;
}

}  // namespace guideway::daemon
