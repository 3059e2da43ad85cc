#pragma once
// Where guidewayd's threads may run on a machine-tool controller PC, and how politely: [daemon]
// cpu_affinity (default: every CPU the process may use except those the kernel isolates for a
// real-time loop, /sys/devices/system/cpu/isolated, i.e. isolcpus=) and nice. Applied once to the
// main thread before any other thread or child process starts, so every one inherits it
// (docs/systemd.md, "On the controller PC").

#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace guideway::daemon {

// A kernel CPU list ("0-3,6", "" for none, surrounding whitespace and a trailing newline allowed).
// nullopt with `error` when malformed or a CPU number is beyond what this system can address.
std::optional<std::set<int>> parse_cpu_list(std::string_view text, std::string& error);
std::string format_cpu_list(const std::set<int>& cpus);

// The isolated CPUs: /sys/devices/system/cpu/isolated, or the file $GUIDEWAY_CPU_ISOLATED_FILE
// names (a test stands in for the kernel's list there). Empty when the file is missing.
std::set<int> isolated_cpus();

struct PlacementRequest {
  std::optional<std::set<int>> cpus;  // cpu_affinity; nullopt: every allowed CPU but the isolated ones
  std::optional<int> nice;
};

struct PlacementResult {
  std::set<int> cpus;                 // where the threads run now
  std::set<int> isolated;             // what the kernel isolates
  std::vector<std::string> warnings;  // what could not be done, and why (the daemon runs on)
};

// Sets the calling thread's CPU affinity and nice value: call it before any thread starts.
PlacementResult apply_placement(const PlacementRequest& request);

}  // namespace guideway::daemon
