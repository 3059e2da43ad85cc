// `guideway version|status|watch`: client commands that talk to a running guidewayd.
#include <csignal>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "cli/commands.hpp"
#include "cli/daemon_client.hpp"
#include "core/runtime_paths.hpp"

namespace guideway::cli {

namespace {

DaemonClient connect(const CliContext& ctx) {
  if (!ctx.socket.empty()) return DaemonClient(ctx.socket);
  return DaemonClient::connect_first(client_socket_candidates());
}

void throw_if_error(const nlohmann::json& reply) {
  if (reply.value("class", "") == "ERROR") throw std::runtime_error("daemon: " + reply.value("message", "error"));
}

std::string fmt_count(const nlohmann::json& j, const char* key) {
  return j.contains(key) ? std::to_string(j[key].get<std::uint64_t>()) : "-";
}

void print_status(const nlohmann::json& s) {
  std::cout << "guidewayd " << s.value("release", "?") << ", up " << std::fixed << std::setprecision(1)
            << s.value("uptime_s", 0.0) << " s, config " << s.value("config", "?") << "\n";
  std::cout << "socket " << s.value("socket", "?") << ", state " << s.value("state_dir", "?") << "\n";
  const auto& p = s["pipeline"];
  std::cout << "pipeline: " << p.value("samples", 0) << " samples in the last period, latency mean "
            << std::setprecision(1) << p.value("latency_mean_us", 0.0) << " us, max " << p.value("latency_max_us", 0.0)
            << " us\n";
  std::cout << "clients: " << s["clients"].value("connected", 0) << " connected, "
            << s["clients"].value("dropped_slow", 0) << " dropped as too slow\n";
  const auto& devices = s["devices"];
  if (devices.empty()) {
    std::cout << "devices: none configured\n";
    return;
  }
  std::cout << std::left << std::setw(14) << "DEVICE" << std::setw(18) << "DRIVER" << std::setw(11) << "STATE"
            << std::right << std::setw(10) << "SAMPLES" << std::setw(9) << "BAD" << std::setw(9) << "TIMEOUT"
            << std::setw(7) << "RECON" << std::setw(9) << "OVERRUN" << std::setw(12) << "RING" << "  REASON\n";
  for (const auto& d : devices) {
    const auto& c = d["counters"];
    std::ostringstream ring;
    ring << d["ring"].value("depth", 0) << "/" << d["ring"].value("capacity", 0);
    std::cout << std::left << std::setw(14) << d.value("name", "?") << std::setw(18) << d.value("driver", "?")
              << std::setw(11) << d.value("state", "?") << std::right << std::setw(10) << fmt_count(c, "samples")
              << std::setw(9) << fmt_count(c, "bad_frames") << std::setw(9) << fmt_count(c, "timeouts")
              << std::setw(7) << fmt_count(c, "reconnects") << std::setw(9) << fmt_count(c, "overruns")
              << std::setw(12) << ring.str() << "  " << d.value("reason", "") << "\n";
  }
}

volatile std::sig_atomic_t interrupted = 0;

}  // namespace

namespace {

void add_daemon_commands(CLI::App& app, CliContext& ctx) {
  auto* version = app.add_subcommand("version", "Show the daemon's release and protocol version");
  auto json = std::make_shared<bool>(false);
  version->add_flag("--json", *json, "print the daemon's JSON unchanged");
  version->callback([&ctx, json] {
    DaemonClient c = connect(ctx);
    const nlohmann::json v = c.request({{"class", "version"}}, "VERSION");
    throw_if_error(v);
    if (*json) {
      std::cout << v.dump() << "\n";
    } else {
      std::cout << "guidewayd " << v.value("release", "?") << " (protocol " << v.value("proto_major", 0) << "."
                << v.value("proto_minor", 0) << ") at " << c.address() << "\n";
    }
  });

  auto* status = app.add_subcommand("status", "Show the daemon's devices, counters, rings and clients");
  status->add_flag("--json", *json, "print the daemon's JSON unchanged");
  status->callback([&ctx, json] {
    DaemonClient c = connect(ctx);
    const nlohmann::json s = c.request({{"class", "status"}}, "STATUS");
    throw_if_error(s);
    if (*json) {
      std::cout << s.dump() << "\n";
    } else {
      print_status(s);
    }
  });

  auto* watch = app.add_subcommand("watch", "Print the daemon's published messages as they arrive (Ctrl-C ends)");
  struct WatchOptions {
    std::vector<std::string> classes;
    std::vector<std::string> channels;
    double seconds = 0;
    std::size_t count = 0;
  };
  auto w = std::make_shared<WatchOptions>();
  watch->add_option("--class", w->classes, "classes to receive: STATUS SAMPLE PARAMS EXPLAIN EVENT (default: all but SAMPLE)");
  watch->add_option("--channel", w->channels, "devices or sessions to receive (default: all)");
  watch->add_option("--seconds", w->seconds, "stop after this many seconds (default: run until interrupted)");
  watch->add_option("--count", w->count, "stop after this many messages");
  watch->add_flag("--json", *json, "print one JSON message per line (the default; kept for symmetry)");
  watch->callback([&ctx, w] {
    const auto& [classes, channels, seconds, count] = *w;
    DaemonClient c = connect(ctx);
    nlohmann::json req = {{"class", "watch"}, {"enable", true}};
    if (!classes.empty()) req["classes"] = classes;
    if (!channels.empty()) req["channels"] = channels;
    const nlohmann::json ack = c.request(req, "WATCH");
    throw_if_error(ack);
    std::signal(SIGINT, [](int) { interrupted = 1; });
    const auto start = std::chrono::steady_clock::now();
    std::size_t seen = 0;
    while (!interrupted) {
      if (seconds > 0 && std::chrono::steady_clock::now() - start > std::chrono::duration<double>(seconds)) break;
      auto line = c.read_line(std::chrono::milliseconds(200));
      if (!line) continue;
      std::cout << *line << "\n" << std::flush;
      if (count != 0 && ++seen >= count) break;
    }
  });
}

const CommandGroup daemon_commands(&add_daemon_commands);

}  // namespace

}  // namespace guideway::cli
