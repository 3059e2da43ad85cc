// `guideway version|status|watch`: client commands that talk to a running guidewayd.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "cli/commands.hpp"
#include "cli/daemon_client.hpp"
#include "cli/instrument_print.hpp"
#include "cli/params_print.hpp"
#include "cli/progress.hpp"
#include "cli/session_wait.hpp"
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
              << ses.value("samples", 0) << " samples"
              << (ses.contains("progress") ? ", " + ses["progress"].get<std::string>() : "") << "\n";
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
            << std::setw(7) << "RECON" << std::setw(9) << "OVERRUN" << std::setw(12) << "RING"
            << "  REASON\n";
  for (const auto& d : devices) {
    const auto& c = d["counters"];
    std::ostringstream ring;
    ring << d["ring"].value("depth", 0) << "/" << d["ring"].value("capacity", 0);
    std::cout << std::left << std::setw(name_w) << d.value("name", "?") << std::setw(driver_w) << d.value("driver", "?")
              << std::setw(11) << d.value("state", "?") << std::right << std::setw(10) << fmt_count(c, "samples")
              << std::setw(9) << fmt_count(c, "bad_frames") << std::setw(9) << fmt_count(c, "timeouts") << std::setw(7)
              << fmt_count(c, "reconnects") << std::setw(9) << fmt_count(c, "overruns") << std::setw(12) << ring.str()
              << "  " << d.value("reason", "") << "\n";
    // The driver's own counters under its row, only those that counted something (zeros are the norm).
    std::string own;
    const nlohmann::json counters = d.value("driver_counters", nlohmann::json::object());  // absent before protocol 1.1
    for (const auto& [name, value] : counters.items()) {
      if (value.is_number_unsigned() && value.get<std::uint64_t>() != 0) {
        own += (own.empty() ? "" : ", ") + name + "=" + value.dump();
      }
    }
    if (!own.empty())
      std::cout << std::string(static_cast<std::size_t>(name_w), ' ') << "driver counters: " << own << "\n";
    print_device_instrument(d, name_w, std::cout);
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

// Every command of the group prints the daemon's reply as it came with --json.
struct JsonOption {
  bool json = false;
  void add(CLI::App& cmd) { cmd.add_flag("--json", json, "print the daemon's JSON unchanged"); }
};

// The reply of the daemon to `request` (a reply of class `reply`); an ERROR is thrown (printed first with
// --json).
nlohmann::json ask(DaemonClient& c, const nlohmann::json& request, results::MessageClass reply, bool json) {
  const nlohmann::json r = c.request(request, reply);
  throw_if_error_reply(r, json);
  return r;
}

void run_version(const JsonOption& o, CliContext& ctx) {
  DaemonClient c = connect(ctx);
  const nlohmann::json v =
      ask(c, results::request(results::RequestClass::version), results::MessageClass::version, o.json);
  if (o.json) {
    std::cout << v.dump() << "\n";
  } else {
    std::cout << "guidewayd " << v.value("release", "?") << " (protocol " << v.value("proto_major", 0) << "."
              << v.value("proto_minor", 0) << ") at " << c.address() << "\n";
  }
}

void run_status(const JsonOption& o, CliContext& ctx) {
  DaemonClient c = connect(ctx);
  const nlohmann::json s =
      ask(c, results::request(results::RequestClass::status), results::MessageClass::status, o.json);
  if (o.json) {
    std::cout << s.dump() << "\n";
  } else {
    print_status(s);
  }
}

struct StartOptions {
  std::string kind;
  std::string device;
  std::vector<std::string> settings;
  std::string test;
  bool wait = false;
  bool quiet = false;
  double timeout_s = 600;
  bool json = false;
  void add(CLI::App& cmd) {
    cmd.add_option("kind", kind, "session kind: " + results::session_kind_names())->required();
    cmd.add_option("--device", device, "device name (default: the first device that can run this kind)");
    cmd.add_option("--test", test,
                   "dbb: the test, " + std::string(results::dbb_test.choices) + " (default " +
                       std::string(results::dbb_test.fallback_text) + "; the same as --set test=NAME)");
    cmd.add_option("--set", settings, session_options_help());
    cmd.add_flag("--wait", wait, "wait for the identified parameters and print them");
    cmd.add_option("--timeout", timeout_s, "with --wait: give up after this many seconds (default 600)");
    cmd.add_flag("--quiet", quiet, "with --wait: no progress lines on standard error while the session runs");
    cmd.add_flag("--json", json, "print the daemon's JSON unchanged");
  }
};

void run_start(const StartOptions& o, CliContext& ctx) {
  // Checked before the session starts: a session must not be left running by a bad option.
  if (!(o.timeout_s > 0)) throw std::runtime_error("--timeout must be a positive number of seconds");
  nlohmann::json req =
      results::request(results::RequestClass::start, {{"kind", o.kind}, {"options", nlohmann::json::object()}});
  if (!o.device.empty()) req["device"] = o.device;
  if (!o.test.empty()) req["options"][std::string(results::dbb_test.name)] = o.test;
  for (const auto& kv : o.settings) {
    auto [k, v] = parse_setting(kv);
    if (k == results::dbb_test.name && !o.test.empty())
      throw std::runtime_error("--test and --set test=... both give the test: give one");
    req["options"][k] = v;
  }
  DaemonClient c = connect(ctx);
  if (o.wait) watch_session_progress(c);
  const nlohmann::json r = ask(c, req, results::MessageClass::session, o.json);
  const std::string session = r.value("session", "");
  if (o.json) {
    std::cout << r.dump() << "\n";
  } else {
    std::cout << "session " << session << " started\n";
    print_warnings(r, std::cout);
  }
  if (o.wait) wait_for_params(c, session, o.timeout_s, o.quiet, o.json);
}

struct StopOptions : JsonOption {
  std::string session;
  void add(CLI::App& cmd) {
    cmd.add_option("session", session, "session name (see guideway status)");
    JsonOption::add(cmd);
  }
};

void run_stop(const StopOptions& o, CliContext& ctx) {
  DaemonClient c = connect(ctx);
  nlohmann::json req = results::request(results::RequestClass::stop);
  if (!o.session.empty()) req["session"] = o.session;
  const nlohmann::json r = ask(c, req, results::MessageClass::session, o.json);
  if (o.json) {
    std::cout << r.dump() << "\n";
  } else {
    for (const auto& n : r["sessions"]) std::cout << "session " << n.get<std::string>() << " finishing\n";
  }
}

struct ParamsOptions : JsonOption {
  std::string kind;
  void add(CLI::App& cmd) {
    cmd.add_option("kind", kind, "session kind (default: the most recent of any kind)");
    JsonOption::add(cmd);
  }
};

void run_params(const ParamsOptions& o, CliContext& ctx) {
  DaemonClient c = connect(ctx);
  nlohmann::json req = results::request(results::RequestClass::params);
  if (!o.kind.empty()) req["kind"] = o.kind;
  const nlohmann::json r = ask(c, req, results::MessageClass::params, o.json);
  if (o.json) {
    std::cout << r.dump() << "\n";
  } else {
    print_params(r);
  }
}

void run_recordings(const JsonOption& o, CliContext& ctx) {
  DaemonClient c = connect(ctx);
  const nlohmann::json r =
      ask(c, results::request(results::RequestClass::recordings), results::MessageClass::recordings, o.json);
  if (o.json) {
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
}

struct WatchOptions : JsonOption {
  std::vector<std::string> classes;
  std::vector<std::string> channels;
  double seconds = 0;
  std::size_t count = 0;
  bool si = false;
  void add(CLI::App& cmd) {
    cmd.add_option("--class", classes,
                   "classes to receive: " + results::published_class_names() + " (default: all but " +
                       std::string(results::to_string(results::MessageClass::sample)) + ")");
    cmd.add_option("--channel", channels, "devices or sessions to receive (default: all)");
    cmd.add_option("--seconds", seconds, "stop after this many seconds (default: run until interrupted)");
    cmd.add_option("--count", count, "stop after this many messages");
    cmd.add_flag("--json", json, "print the daemon's JSON messages unchanged, one per line");
    cmd.add_flag("--si", si, "sample values in SI units as the daemon sends them (m, rad) instead of µm/mm and arcsec");
  }
};

// The unit of each device's channels, for the readable lines: SAMPLE values carry no unit, STATUS names them.
ChannelUnits channel_units(DaemonClient& c) {
  ChannelUnits units;
  const nlohmann::json s = c.request(results::request(results::RequestClass::status), results::MessageClass::status);
  const nlohmann::json devices = s.value("devices", nlohmann::json::array());
  for (const auto& d : devices) {
    const nlohmann::json device_channels = d.value("channels", nlohmann::json::array());
    for (const auto& ch : device_channels)
      units[d.value("name", "") + "/" + ch.value("name", "")] = ch.value("unit", "");
  }
  return units;
}

void run_watch(const WatchOptions& o, CliContext& ctx) {
  DaemonClient c = connect(ctx);
  const ChannelUnits units = o.json ? ChannelUnits{} : channel_units(c);
  nlohmann::json req = results::request(results::RequestClass::watch, {{"enable", true}});
  if (!o.classes.empty()) req["classes"] = o.classes;
  if (!o.channels.empty()) req["channels"] = o.channels;
  ask(c, req, results::MessageClass::watch, o.json);
  std::signal(SIGINT, [](int) { interrupted = 1; });
  const auto began = std::chrono::steady_clock::now();
  std::size_t seen = 0;
  ChannelDisplay display;
  while (!interrupted) {
    if (o.seconds > 0 && std::chrono::steady_clock::now() - began > std::chrono::duration<double>(o.seconds)) break;
    auto line = c.read_line(std::chrono::milliseconds(200));
    if (!line) continue;
    if (o.json) {
      std::cout << *line << "\n" << std::flush;
    } else {
      const auto m = nlohmann::json::parse(*line, nullptr, false);
      std::cout << (m.is_object() ? watch_line(m, units, o.si ? nullptr : &display) : *line) << "\n" << std::flush;
    }
    if (o.count != 0 && ++seen >= o.count) break;
  }
}

void add_daemon_commands(CLI::App& app, CliContext& ctx) {
  add_commands(
      app, ctx,
      {command("version", "Show the daemon's release and protocol version", &run_version),
       command("status", "Show the daemon's devices, counters, rings and clients", &run_status),
       command("start", "Start a test session (" + results::session_kind_names() + ") on the daemon", &run_start),
       command("stop", "End a running session (all running sessions when none is named)", &run_stop),
       command("params", "Show the latest identified parameters (with standard uncertainties)", &run_params),
       command("recordings", "List the daemon's recordings", &run_recordings),
       command("watch", "Print the daemon's published messages as they arrive (Ctrl-C ends)", &run_watch)});
}

const CommandGroup daemon_commands(&add_daemon_commands);

}  // namespace

}  // namespace guideway::cli
