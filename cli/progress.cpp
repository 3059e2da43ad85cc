// A long command's progress on standard error (progress.hpp).
#include "cli/progress.hpp"

#include <cctype>
#include <iostream>

namespace guideway::cli {

namespace {

using Clock = std::chrono::steady_clock;

// The text without its numbers: a count that grows is the same phase, a new step is not.
std::string phase_of(const std::string& what) {
  std::string p;
  for (char c : what) {
    const bool digit = std::isdigit(static_cast<unsigned char>(c)) != 0;
    if (!digit)
      p += c;
    else if (p.empty() || p.back() != '#')
      p += '#';
  }
  return p;
}

}  // namespace

Progress::Progress(std::string command, bool quiet, double quiet_start_s,
                   std::function<void(const std::string& line)> print)
    : command_(std::move(command)), quiet_start_(quiet_start_s), print_(std::move(print)) {
  if (!print_) print_ = [](const std::string& line) { std::cerr << line << "\n" << std::flush; };
  if (!quiet) thread_ = std::thread([this] { tick(); });
}

Progress::~Progress() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void Progress::doing(std::string what) {
  {
    std::lock_guard lock(mutex_);
    what_ = std::move(what);
  }
  wake_.notify_all();
}

void Progress::tick() {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    print_due(Clock::now());
    wake_.wait_for(lock, std::chrono::milliseconds(250));
  }
}

void Progress::print_due(Clock::time_point now) {  // under mutex_
  if (what_.empty() || now - began_ < quiet_start_) return;
  const std::string phase = phase_of(what_);
  const auto since = now - last_print_;
  if (phase == last_phase_ ? since < std::chrono::seconds(5) : since < std::chrono::seconds(1)) return;
  last_phase_ = phase;
  last_print_ = now;
  const auto elapsed_s = std::chrono::duration_cast<std::chrono::seconds>(now - began_).count();
  print_("  [" + std::to_string(elapsed_s) + " s] " + (command_.empty() ? "" : command_ + ": ") + what_);
}

}  // namespace guideway::cli
