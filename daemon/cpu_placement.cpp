// Where and how politely guidewayd's threads run (cpu_placement.hpp): cpu_affinity and nice, set once at start.
#include "daemon/cpu_placement.hpp"

#include <sched.h>
#include <sys/resource.h>

#include <cerrno>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

namespace guideway::daemon {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\n')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\n')) s.remove_suffix(1);
  return s;
}

bool parse_cpu(std::string_view s, int& cpu) {
  s = trim(s);
  const auto r = std::from_chars(s.data(), s.data() + s.size(), cpu);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && cpu >= 0;
}

}  // namespace

std::optional<std::set<int>> parse_cpu_list(std::string_view text, std::string& error) {
  std::set<int> cpus;
  text = trim(text);
  while (!text.empty()) {
    const auto comma = text.find(',');
    const std::string_view item = trim(text.substr(0, comma));
    text = comma == std::string_view::npos ? std::string_view() : text.substr(comma + 1);
    const auto dash = item.find('-');
    int first = 0;
    int last = 0;
    if (!parse_cpu(item.substr(0, dash), first) ||
        (dash != std::string_view::npos && !parse_cpu(item.substr(dash + 1), last))) {
      error = "\"" + std::string(item) + "\" is not a CPU number or range (a CPU list looks like \"0-3,6\")";
      return std::nullopt;
    }
    if (dash == std::string_view::npos) last = first;
    if (last < first) {
      error = "range \"" + std::string(item) + "\" goes backwards";
      return std::nullopt;
    }
    if (last >= CPU_SETSIZE) {
      error =
          "CPU " + std::to_string(last) + " is beyond what this system addresses (" + std::to_string(CPU_SETSIZE) + ")";
      return std::nullopt;
    }
    for (int c = first; c <= last; ++c) cpus.insert(c);
  }
  return cpus;
}

std::string format_cpu_list(const std::set<int>& cpus) {
  std::string out;
  for (auto it = cpus.begin(); it != cpus.end();) {
    const int first = *it;
    int last = first;
    while (++it != cpus.end() && *it == last + 1) last = *it;
    if (!out.empty()) out += ',';
    out += std::to_string(first);
    if (last != first) out += '-' + std::to_string(last);
  }
  return out;
}

std::set<int> isolated_cpus() {
  const char* over = std::getenv("GUIDEWAY_CPU_ISOLATED_FILE");
  std::ifstream in(over != nullptr && *over != '\0' ? over : "/sys/devices/system/cpu/isolated");
  if (!in) return {};
  std::stringstream text;
  text << in.rdbuf();
  std::string error;
  return parse_cpu_list(text.str(), error).value_or(std::set<int>{});
}

PlacementResult apply_placement(const PlacementRequest& request) {
  PlacementResult r;
  r.isolated = isolated_cpus();
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (::sched_getaffinity(0, sizeof allowed, &allowed) != 0) {
    r.warnings.push_back(std::string("sched_getaffinity: ") + std::strerror(errno));
    return r;
  }
  std::set<int> current;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &allowed)) current.insert(c);
  std::set<int> want;
  if (request.cpus) {
    want = *request.cpus;
    for (const int c : want) {
      if (r.isolated.count(c) != 0)
        r.warnings.push_back("cpu_affinity includes CPU " + std::to_string(c) +
                             ", which the kernel isolates (isolcpus) for a real-time task");
    }
  } else {
    // Every CPU this process may use (systemd's CPUAffinity=, taskset) but the isolated ones.
    for (const int c : current)
      if (r.isolated.count(c) == 0) want.insert(c);
    if (want.empty()) {
      r.warnings.push_back("every CPU this process may use (" + format_cpu_list(current) +
                           ") is isolated: the threads stay where they may run; set [daemon] cpu_affinity");
      want = current;
    }
  }
  cpu_set_t set;
  CPU_ZERO(&set);
  for (const int c : want) CPU_SET(c, &set);
  if (want != current && ::sched_setaffinity(0, sizeof set, &set) != 0) {
    r.warnings.push_back("cpu_affinity " + format_cpu_list(want) + ": " + std::strerror(errno) +
                         " (the threads stay on " + format_cpu_list(current) + ")");
    r.cpus = current;
  } else {
    r.cpus = want;
  }
  if (request.nice) {
    // The calling thread's (Linux: each thread has its own), inherited by the threads it starts.
    if (::setpriority(PRIO_PROCESS, 0, *request.nice) != 0) {
      r.warnings.push_back("nice " + std::to_string(*request.nice) + ": " + std::strerror(errno) +
                           (*request.nice < 0 ? " (a negative nice needs CAP_SYS_NICE)" : ""));
    }
  }
  return r;
}

}  // namespace guideway::daemon
