// `guideway version|status|watch`: client commands that talk to a running guidewayd.
#include <algorithm>
#include <csignal>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "cli/commands.hpp"
#include "cli/daemon_client.hpp"
#include "cli/params_print.hpp"
#include "core/runtime_paths.hpp"
#include "results/session_kinds.hpp"

namespace guideway::cli {

namespace {

DaemonClient connect(const CliContext& ctx) { return connect_daemon(ctx.socket); }

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
  if (const auto m = s.value("mqtt", nlohmann::json()); m.is_object()) {  // [mqtt]: docs/plant.md
    std::cout << "mqtt: " << m.value("state", "?") << " (" << m.value("broker", "?") << ", machine "
              << m.value("machine", "?") << ", since " << m.value("since", "?") << "), " << m.value("queued", 0)
              << " queued, " << m.value("delivered", 0) << " delivered, " << m.value("dropped", 0) << " dropped, "
              << m.value("refused", 0) << " refused\n";
    if (m.contains("last_error") && m.value("state", "") != "connected")
      std::cout << "  last error: " << m.value("last_error", "") << "\n";
  }
  for (const auto& ses : s.value("sessions", nlohmann::json::array())) {
    std::cout << "session " << ses.value("session", "?") << ": " << ses.value("state", "?") << ", "
              << ses.value("samples", 0) << " samples" << (ses.contains("progress") ? ", " + ses["progress"].get<std::string>() : "")
              << "\n";
    // A disk error loses data: never only in the JSON.
    if (ses.contains("recording_error")) std::cout << "  recording error: " << ses.value("recording_error", "") << "\n";
  }
  const auto& devices = s["devices"];
  if (devices.empty()) {
    std::cout << "devices: none configured\n";
    return;
  }
  int name_w = 7, driver_w = 7;
  for (const auto& d : devices) {
    name_w = std::max(name_w, static_cast<int>(d.value("name", "").size()) + 2);
    driver_w = std::max(driver_w, static_cast<int>(d.value("driver", "").size()) + 2);
  }
  std::cout << std::left << std::setw(name_w) << "DEVICE" << std::setw(driver_w) << "DRIVER" << std::setw(11) << "STATE"
            << std::right << std::setw(10) << "SAMPLES" << std::setw(9) << "BAD" << std::setw(9) << "TIMEOUT"
            << std::setw(7) << "RECON" << std::setw(9) << "OVERRUN" << std::setw(12) << "RING" << "  REASON\n";
  for (const auto& d : devices) {
    const auto& c = d["counters"];
    std::ostringstream ring;
    ring << d["ring"].value("depth", 0) << "/" << d["ring"].value("capacity", 0);
    std::cout << std::left << std::setw(name_w) << d.value("name", "?") << std::setw(driver_w) << d.value("driver", "?")
              << std::setw(11) << d.value("state", "?") << std::right << std::setw(10) << fmt_count(c, "samples")
              << std::setw(9) << fmt_count(c, "bad_frames") << std::setw(9) << fmt_count(c, "timeouts")
              << std::setw(7) << fmt_count(c, "reconnects") << std::setw(9) << fmt_count(c, "overruns")
              << std::setw(12) << ring.str() << "  " << d.value("reason", "") << "\n";
    // The driver's own counters under its row, only those that counted something (zeros are the norm).
    std::string own;
    const nlohmann::json counters = d.value("driver_counters", nlohmann::json::object());  // absent before protocol 1.1
    for (const auto& [name, value] : counters.items()) {
      if (value.is_number_unsigned() && value.get<std::uint64_t>() != 0) {
        own += (own.empty() ? "" : ", ") + name + "=" + value.dump();
      }
    }
    if (!own.empty()) std::cout << std::string(static_cast<std::size_t>(name_w), ' ') << "driver counters: " << own << "\n";
  }
}

// The --set help of `guideway start`: every kind's options with their defaults (results/session_kinds.hpp).
std::string session_options_help() {
  std::string help = "session option KEY=VALUE (repeatable); every option has a default.";
  for (const results::SessionKindInfo* kind : results::session_kinds()) {
    help += " " + std::string(kind->name) + ":";
    for (std::size_t i = 0; i < kind->options.size(); ++i)
      help += (i ? ", " : " ") + results::option_with_default(*kind->options[i]);
    help += ";";
  }
  return help + " (all: docs/protocol.md)";
}

volatile std::sig_atomic_t interrupted = 0;

// A KEY=VALUE option: VALUE is read as JSON when it parses (numbers, true/false, arrays and objects
// such as dbb's patterns=[{...}]), else as a string.
std::pair<std::string, nlohmann::json> parse_setting(const std::string& kv) {
  const auto eq = kv.find('=');
  if (eq == std::string::npos || eq == 0) throw std::runtime_error("--set expects KEY=VALUE, got \"" + kv + "\"");
  const std::string value = kv.substr(eq + 1);
  nlohmann::json v = nlohmann::json::parse(value, nullptr, false);
  if (v.is_discarded() || v.is_null()) v = value;
  return {kv.substr(0, eq), v};
}

}  // namespace

namespace {

void add_daemon_commands(CLI::App& app, CliContext& ctx) {
  auto* version = app.add_subcommand("version", "Show the daemon's release and protocol version");
  auto json = std::make_shared<bool>(false);
  version->add_flag("--json", *json, "print the daemon's JSON unchanged");
  version->callback([&ctx, json] {
    DaemonClient c = connect(ctx);
    const nlohmann::json v = c.request({{"class", "version"}}, results::MessageClass::version);
    throw_if_error_reply(v, *json);
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
    const nlohmann::json s = c.request({{"class", "status"}}, results::MessageClass::status);
    throw_if_error_reply(s, *json);
    if (*json) {
      std::cout << s.dump() << "\n";
    } else {
      print_status(s);
    }
  });

  struct StartOptions {
    std::string kind;
    std::string device;
    std::vector<std::string> settings;
    bool wait = false;
    double timeout_s = 600;
  };
  auto so = std::make_shared<StartOptions>();
  auto* start =
      app.add_subcommand("start", "Start a test session (" + results::session_kind_names() + ") on the daemon");
  start->add_option("kind", so->kind, "session kind: " + results::session_kind_names())->required();
  start->add_option("--device", so->device, "device name (default: the first device that can run this kind)");
  start->add_option("--set", so->settings, session_options_help());
  start->add_flag("--wait", so->wait, "wait for the identified parameters and print them");
  start->add_option("--timeout", so->timeout_s, "with --wait: give up after this many seconds (default 600)");
  start->add_flag("--json", *json, "print the daemon's JSON unchanged");
  start->callback([&ctx, so, json] {
    // Checked before the session starts: a session must not be left running by a bad option.
    if (!(so->timeout_s > 0)) throw std::runtime_error("--timeout must be a positive number of seconds");
    for (const auto& kv : so->settings) parse_setting(kv);
    DaemonClient c = connect(ctx);
    nlohmann::json req = {{"class", "start"}, {"kind", so->kind}, {"options", nlohmann::json::object()}};
    if (!so->device.empty()) req["device"] = so->device;
    for (const auto& kv : so->settings) {
      auto [k, v] = parse_setting(kv);
      req["options"][k] = v;
    }
    if (so->wait)
      c.request(
          {{"class", "watch"},
           {"classes",
            {results::to_string(results::MessageClass::params), results::to_string(results::MessageClass::event)}}},
          results::MessageClass::watch);
    const nlohmann::json r = c.request(req, results::MessageClass::session);
    throw_if_error_reply(r, *json);
    const std::string session = r.value("session", "");
    if (*json) {
      std::cout << r.dump() << "\n";
    } else {
      std::cout << "session " << session << " started\n";
    }
    if (!so->wait) return;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(so->timeout_s);
    while (std::chrono::steady_clock::now() < deadline) {
      auto line = c.read_line(std::chrono::milliseconds(500));
      if (!line) continue;
      const auto m = nlohmann::json::parse(*line, nullptr, false);
      if (m.is_discarded() || m.value("session", "") != session) continue;
      if (results::has_class(m, results::MessageClass::event) && m.value("event", "") == "session_failed") {
        if (*json) std::cout << m.dump() << "\n";
        throw std::runtime_error("session " + session + " failed: " + m.value("reason", "?"));
      }
      if (results::has_class(m, results::MessageClass::params)) {
        if (*json) {
          std::cout << m.dump() << "\n";
        } else {
          print_params(m);
        }
        return;
      }
    }
    std::ostringstream why;
    why << "no parameters for session " << session << " within " << so->timeout_s << " s (it goes on: guideway stop "
        << session << " ends it)";
    throw std::runtime_error(why.str());
  });

  auto stop_session = std::make_shared<std::string>();
  auto* stop = app.add_subcommand("stop", "End a running session (all running sessions when none is named)");
  stop->add_option("session", *stop_session, "session name (see guideway status)");
  stop->add_flag("--json", *json, "print the daemon's JSON unchanged");
  stop->callback([&ctx, stop_session, json] {
    DaemonClient c = connect(ctx);
    nlohmann::json req = {{"class", "stop"}};
    if (!stop_session->empty()) req["session"] = *stop_session;
    const nlohmann::json r = c.request(req, results::MessageClass::session);
    throw_if_error_reply(r, *json);
    if (*json) {
      std::cout << r.dump() << "\n";
    } else {
      for (const auto& n : r["sessions"]) std::cout << "session " << n.get<std::string>() << " finishing\n";
    }
  });

  auto params_kind = std::make_shared<std::string>();
  auto* params = app.add_subcommand("params", "Show the latest identified parameters (with standard uncertainties)");
  params->add_option("kind", *params_kind, "session kind (default: the most recent of any kind)");
  params->add_flag("--json", *json, "print the daemon's JSON unchanged");
  params->callback([&ctx, params_kind, json] {
    DaemonClient c = connect(ctx);
    nlohmann::json req = {{"class", "params"}};
    if (!params_kind->empty()) req["kind"] = *params_kind;
    const nlohmann::json r = c.request(req, results::MessageClass::params);
    throw_if_error_reply(r, *json);
    if (*json) {
      std::cout << r.dump() << "\n";
    } else {
      print_params(r);
    }
  });

  auto* recordings = app.add_subcommand("recordings", "List the daemon's recordings");
  recordings->add_flag("--json", *json, "print the daemon's JSON unchanged");
  recordings->callback([&ctx, json] {
    DaemonClient c = connect(ctx);
    const nlohmann::json r = c.request({{"class", "recordings"}}, results::MessageClass::recordings);
    throw_if_error_reply(r, *json);
    if (*json) {
      std::cout << r.dump() << "\n";
      return;
    }
    const bool none = r.value("recordings", nlohmann::json::array()).empty();
    std::cout << "recordings in " << r.value("dir", "?") << ":" << (none ? " none yet (every session records one)" : "")
              << "\n";
    for (const auto& rec : r["recordings"]) {
      std::cout << "  " << std::left << std::setw(70) << rec.value("file", "?") << std::right << std::setw(12)
                << rec.value("bytes", 0) << (rec.value("complete", false) ? "" : "  (incomplete)") << "\n";
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
  watch->add_option("--class", w->classes,
                    "classes to receive: " + results::published_class_names() + " (default: all but " +
                        std::string(results::to_string(results::MessageClass::sample)) + ")");
  watch->add_option("--channel", w->channels, "devices or sessions to receive (default: all)");
  watch->add_option("--seconds", w->seconds, "stop after this many seconds (default: run until interrupted)");
  watch->add_option("--count", w->count, "stop after this many messages");
  watch->add_flag("--json", *json, "print the daemon's JSON messages unchanged, one per line");
  watch->callback([&ctx, w, json] {
    const auto& [classes, channels, seconds, count] = *w;
    DaemonClient c = connect(ctx);
    ChannelUnits units;  // for the readable lines: SAMPLE values carry no unit, STATUS names them
    if (!*json) {
      const nlohmann::json s = c.request({{"class", "status"}}, results::MessageClass::status);
      const nlohmann::json devices = s.value("devices", nlohmann::json::array());
      for (const auto& d : devices) {
        const nlohmann::json device_channels = d.value("channels", nlohmann::json::array());
        for (const auto& ch : device_channels) {
          units[d.value("name", "") + "/" + ch.value("name", "")] = ch.value("unit", "");
        }
      }
    }
    nlohmann::json req = {{"class", "watch"}, {"enable", true}};
    if (!classes.empty()) req["classes"] = classes;
    if (!channels.empty()) req["channels"] = channels;
    const nlohmann::json ack = c.request(req, results::MessageClass::watch);
    throw_if_error_reply(ack, *json);
    std::signal(SIGINT, [](int) { interrupted = 1; });
    const auto began = std::chrono::steady_clock::now();
    std::size_t seen = 0;
    while (!interrupted) {
      if (seconds > 0 && std::chrono::steady_clock::now() - began > std::chrono::duration<double>(seconds)) break;
      auto line = c.read_line(std::chrono::milliseconds(200));
      if (!line) continue;
      if (*json) {
        std::cout << *line << "\n" << std::flush;
      } else {
        const auto m = nlohmann::json::parse(*line, nullptr, false);
        std::cout << (m.is_object() ? watch_line(m, units) : *line) << "\n" << std::flush;
      }
      if (count != 0 && ++seen >= count) break;
    }
  });
}

const CommandGroup daemon_commands(&add_daemon_commands);

}  // namespace

}  // namespace guideway::cli
