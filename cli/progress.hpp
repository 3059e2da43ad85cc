#pragma once
// What a long command is doing, on standard error, so that a slow run is told from a stuck one: the one
// form of progress of `guideway` (start --wait, explain, identify, compensate --verify, report), as
// "  [12 s] explain: looking for effect 2: trying backlash (3 of 14)". Nothing while the command is
// younger than its quiet start (a command that ends in 2 s prints nothing); then a line when what it
// does changes (its text but for the numbers in it; at most one a second) and otherwise every 5 s. A
// thread of its own prints, so a line comes also while one long call runs. Quiet (`--quiet`, `--json`):
// nothing at all. Thread safe.

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace guideway::cli {

class Progress {
 public:
  // `command` heads every line ("explain"; "" for none); `quiet_start_s` is the time nothing is printed;
  // `print` takes each line (default: standard error).
  Progress(std::string command, bool quiet, double quiet_start_s = 2.0,
           std::function<void(const std::string& line)> print = {});
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // What the command does now ("" = nothing to say).
  void doing(std::string what);

 private:
  void tick();
  void print_due(std::chrono::steady_clock::time_point now);

  std::string command_;
  std::chrono::steady_clock::time_point began_ = std::chrono::steady_clock::now();
  std::chrono::duration<double> quiet_start_;
  std::function<void(const std::string&)> print_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::string what_;
  std::string last_phase_;
  std::chrono::steady_clock::time_point last_print_{};
  std::thread thread_;  // last: started when the rest is ready
};

}  // namespace guideway::cli
