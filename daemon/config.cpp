// guidewayd's configuration read and validated (config.hpp): errors with file, line and key.
#include "daemon/config.hpp"
#include "daemon/cpu_placement.hpp"
#include "daemon/instrument_config.hpp"
#include "daemon/mqtt_config.hpp"

#include <arpa/inet.h>
#include <grp.h>

#include <algorithm>
#include <bit>
#include <filesystem>
#include <set>

#include <nlohmann/json.hpp>

#include "core/runtime_paths.hpp"
#include "drivers/driver.hpp"
#include "drivers/ring_capacity.hpp"
#include "dsp/wavelet.hpp"

namespace guideway::daemon {

namespace {

constexpr std::string_view embedded_default =
#include "default_config.inc"
    ;

void parse_listen(const TableReader& t, DaemonConfig& c) {
  const std::string listen = t.get_string("tcp_listen", "");
  if (listen.empty()) return;
  const auto colon = listen.rfind(':');
  if (colon == std::string::npos || colon == 0) t.fail("tcp_listen", "expected HOST:PORT, e.g. \"127.0.0.1:2947\"");
  c.tcp_host = listen.substr(0, colon);
  in_addr address{};
  if (inet_pton(AF_INET, c.tcp_host.c_str(), &address) != 1) {  // checked here: --check-config, file:line
    t.fail("tcp_listen", "HOST must be an IPv4 address such as 127.0.0.1, got \"" + c.tcp_host + "\"");
  }
  try {
    std::size_t used = 0;
    const int port = std::stoi(listen.substr(colon + 1), &used);
    if (used != listen.size() - colon - 1 || port < 0 || port > 65535) throw std::out_of_range("port");
    c.tcp_port = port;
  } catch (const std::exception&) {
    t.fail("tcp_listen", "port must be a number from 0 to 65535");
  }
  if (c.tcp_port == 0) c.tcp_port = -1;  // "any free port" (tests); 0 in the struct means off
}

mode_t parse_mode(const TableReader& t) {
  const std::string text = t.get_string("socket_mode", "0660");
  std::size_t used = 0;
  unsigned long v = 0;
  try {
    v = std::stoul(text, &used, 8);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || v > 0777) t.fail("socket_mode", "expected an octal mode such as \"0660\"");
  if ((v & 0002) != 0)
    t.fail("socket_mode", "world-writable (" + text +
                              "): any local user could start and stop sessions; give the "
                              "users a group (socket_group) and 0660");
  return static_cast<mode_t>(v);
}

// A table's ring_capacity, else `fallback` (nullopt: the ring-size rule's, drivers/ring_capacity.hpp).
std::optional<std::size_t> ring_capacity(const TableReader& t, std::optional<std::size_t> fallback) {
  if (!t.has("ring_capacity")) return fallback;
  const auto v = static_cast<std::size_t>(
      t.get_int("ring_capacity", 0, 2, static_cast<std::int64_t>(drivers::max_ring_capacity)));
  if (!std::has_single_bit(v)) t.fail("ring_capacity", "must be a power of two");
  return v;
}

// A TOML value as JSON (session options: numbers, strings, booleans, arrays and tables of them).
nlohmann::json toml_to_json(const toml::node& n) {
  if (const auto* t = n.as_table()) {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& [k, v] : *t) j[std::string(k.str())] = toml_to_json(v);
    return j;
  }
  if (const auto* a = n.as_array()) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& v : *a) j.push_back(toml_to_json(v));
    return j;
  }
  if (const auto v = n.value<std::int64_t>(); v && n.is_integer()) return *v;
  if (const auto v = n.value<double>()) return *v;
  if (const auto v = n.value<bool>()) return *v;
  if (const auto v = n.value<std::string>()) return *v;
  return nullptr;
}

DaemonConfig::SessionTrigger parse_session_trigger(const TableReader& t, const DaemonConfig& c) {
  DaemonConfig::SessionTrigger s;
  s.device = t.require_string("device");
  if (std::none_of(c.devices.begin(), c.devices.end(), [&](const auto& d) { return d.name == s.device; }))
    t.fail("device", "no enabled [[device]] is named \"" + s.device + "\"");
  s.channel = t.require_string("channel");
  s.kind = t.require_string("kind");
  s.on_device = t.get_string("session_device", "");
  s.end_after_s = t.get_double("end_after_s", s.end_after_s, 0.0, 3600.0);
  nlohmann::json options = nlohmann::json::object();
  if (const auto o = t.table("options")) options = toml_to_json(o->raw());
  s.options = options.dump();
  t.reject_unknown_keys();
  s.table = std::make_shared<TableReader>(t);
  return s;
}

DaemonConfig from_table(toml::table table, const std::string& file_name) {
  DaemonConfig c;
  c.source = file_name;
  c.root = std::make_shared<toml::table>(std::move(table));
  TableReader top(*c.root, file_name, "");
  if (auto d = top.table("daemon")) {
    c.socket_path = d->get_string("socket", "");
    c.socket_mode = parse_mode(*d);
    c.socket_group = d->get_string("socket_group", "");
    // Checked here, not first at bind time: --check-config catches it, and the error names the line.
    if (!c.socket_group.empty() && getgrnam(c.socket_group.c_str()) == nullptr) {
      d->fail("socket_group", "no group named \"" + c.socket_group + "\" on this system");
    }
    parse_listen(*d, c);
    c.state_dir = d->get_string("state_dir", "");
    c.plugin_dir = d->get_string("plugin_dir", "");
    c.log_level = d->get_choice("log_level", "info", {"trace", "debug", "info", "warn", "error", "critical", "off"});
    c.status_period_s = d->get_double("status_period_s", 1.0, 0.05, 3600.0);
    c.sample_publish_hz = d->get_double("sample_publish_hz", 10.0, 0.0, 100000.0);
    c.ring_capacity = ring_capacity(*d, c.ring_capacity);
    c.max_clients = static_cast<std::size_t>(d->get_int("max_clients", 256, 1, 65536));
    c.reserved_clients = static_cast<std::size_t>(d->get_int("reserved_clients", 8, 0, 65536));
    if (c.reserved_clients >= c.max_clients) d->fail("reserved_clients", "must be below max_clients");
    c.idle_timeout_s = d->get_double("idle_timeout_s", 30.0, 0.0, 86400.0);
    c.client_queue_bytes = static_cast<std::size_t>(d->get_int("client_queue_bytes", 4 << 20, 4096, 1LL << 32));
    c.max_request_bytes = static_cast<std::size_t>(d->get_int("max_request_bytes", 16384, 256, 1 << 24));
    if (d->has("cpu_affinity")) {
      std::string error;
      auto cpus = parse_cpu_list(d->get_string("cpu_affinity", ""), error);
      if (!cpus) d->fail("cpu_affinity", error);
      if (cpus->empty()) d->fail("cpu_affinity", "names no CPU (leave it out for every CPU but the isolated ones)");
      c.cpu_affinity = std::move(*cpus);
    }
    if (d->has("nice")) c.nice = static_cast<int>(d->get_int("nice", 0, -20, 19));
    c.refuse_uncalibrated = d->get_bool("refuse_uncalibrated", false);
    c.emulator_executable = d->get_string("emulator_executable", "");
    c.session_analysis = d->get_choice("session_analysis", c.session_analysis, {"process", "daemon"});
    c.analysis_executable = d->get_string("analysis_executable", "");
    if (const std::string m = d->get_string("emulator_machine", ""); !m.empty()) {
      const std::filesystem::path path = config_relative_path(file_name, m);
      std::error_code ec;
      if (!std::filesystem::is_regular_file(path, ec)) d->fail("emulator_machine", "no such file: " + path.string());
      c.emulator_machine = std::filesystem::absolute(path, ec).lexically_normal().string();
    }
    d->reject_unknown_keys();
  }
  std::set<std::string> names;
  for (const TableReader& dev : top.tables("device")) {
    DaemonConfig::Device d;
    d.name = dev.require_string("name");
    if (d.name.empty()) dev.fail("name", "must not be empty");
    if (!names.insert(d.name).second) dev.fail("name", "duplicate device name \"" + d.name + "\"");
    d.driver = dev.require_string("driver");
    d.ring_capacity = ring_capacity(dev, c.ring_capacity);
    d.instrument = parse_instrument(dev, d.driver, utc_today());
    if (!dev.get_bool("enabled", true)) continue;
    d.table = std::make_shared<TableReader>(dev);
    c.devices.push_back(std::move(d));
  }
  for (const TableReader& pt : top.tables("processing")) {
    DaemonConfig::Processing p;
    p.device = pt.require_string("device");
    const auto enabled_device = [&](const DaemonConfig::Device& d) { return d.name == p.device; };
    if (std::none_of(c.devices.begin(), c.devices.end(), enabled_device))
      pt.fail("device", "no enabled [[device]] is named \"" + p.device + "\"");
    p.channel = pt.require_string("channel");
    p.wavelet = pt.get_string("wavelet", p.wavelet);
    try {
      (void)dsp::Wavelet(p.wavelet);
    } catch (const std::invalid_argument& e) {
      pt.fail("wavelet", e.what());
    }
    p.levels = static_cast<int>(pt.get_int("levels", p.levels, 1, 12));
    p.threshold = pt.get_choice("threshold", p.threshold, {"soft", "hard"});
    p.level_dependent = pt.get_bool("level_dependent", p.level_dependent);
    p.noise_window = static_cast<std::size_t>(pt.get_int("noise_window", 1024, 64, 1 << 20));
    const bool enabled = pt.get_bool("enabled", true);
    pt.reject_unknown_keys();
    p.table = std::make_shared<TableReader>(pt);
    if (enabled) c.processing.push_back(std::move(p));
  }
  for (const TableReader& tt : top.tables("session_trigger")) c.session_triggers.push_back(parse_session_trigger(tt, c));
  std::set<std::string> emulator_names;
  for (const TableReader& em : top.tables("emulator")) {
    EmulatorSpec spec;
    spec.name = em.require_string("name");
    if (!emulator_names.insert(spec.name).second) em.fail("name", "duplicate emulator name \"" + spec.name + "\"");
    spec.instrument = em.require_string("instrument");
    spec.line = em.raw().get("name")->source().begin.line;  // the table's own position is not always kept
    spec.args = em.get_strings("args", {});
    if (em.get_bool("enabled", true)) c.emulators.push_back(std::move(spec));
    em.reject_unknown_keys();
  }
  if (c.refuse_uncalibrated) {  // every start on a device without a due date would be refused: say so now
    std::string without;
    for (const DaemonConfig::Device& d : c.devices)
      if (!d.instrument.calibration_due) without += (without.empty() ? "" : ", ") + d.name;
    if (!without.empty())
      top.table("daemon")->fail("refuse_uncalibrated",
                                "every session would be refused on device(s) " + without +
                                    ": no calibration_due is stated (state calibrated_on and calibration_due in "
                                    "their [[device]] tables, or set refuse_uncalibrated = false)");
  }
  if (const auto m = top.table("mqtt")) c.mqtt = parse_mqtt_table(*m, file_name);
  if (const auto e = top.table("explain")) {
    if (e->has("memory_mb")) c.explain_memory_mb = static_cast<std::size_t>(e->get_int("memory_mb", 0, 0, 65536));
    e->reject_unknown_keys();
  }
  top.reject_unknown_keys();
  if (c.socket_path.empty()) c.socket_path = default_socket_path();
  // Checked here, not first at bind time, so that --check-config catches it.
  if (const std::string problem = socket_path_problem(c.socket_path); !problem.empty()) {
    if (const auto d = top.table("daemon"); d && d->has("socket")) d->fail("socket", problem);
    throw ConfigError(file_name, 0, "daemon.socket", "default " + c.socket_path + ": " + problem);
  }
  if (c.state_dir.empty()) c.state_dir = default_state_dir();
  if (c.mqtt) {
    c.mqtt->journal_dir = c.state_dir + "/mqtt-journal";
    // The publisher cannot start without its journal: checked here, so that --check-config refuses it.
    if (const std::string problem = directory_creation_problem(c.mqtt->journal_dir); !problem.empty()) {
      const std::string why = "the MQTT journal " + c.mqtt->journal_dir + " " + problem;
      if (const auto d = top.table("daemon"); d && d->has("state_dir")) d->fail("state_dir", why);
      top.table("mqtt")->fail("broker", why + " (set [daemon] state_dir to a writable directory)");
    }
  }
  if (c.plugin_dir.empty()) c.plugin_dir = drivers::default_plugin_dir();
  return c;
}

}  // namespace

std::filesystem::path config_relative_path(const std::string& config_file, const std::string& value) {
  std::filesystem::path path(value);
  if (path.is_relative() && config_file.find('<') == std::string::npos)
    path = std::filesystem::path(config_file).parent_path() / path;
  return path;
}

DaemonConfig parse_config(std::string_view text, const std::string& file_name) {
  return from_table(parse_toml(text, file_name), file_name);
}

DaemonConfig load_config_file(const std::string& path) { return from_table(parse_toml_file(path), path); }

std::vector<std::string> calibration_warnings(const DaemonConfig& config, const CalendarDate& on) {
  std::vector<std::string> out;
  for (const auto& d : config.devices)
    if (std::string w = calibration_warning(d.name, d.instrument, on); !w.empty()) out.push_back(std::move(w));
  return out;
}

std::vector<std::unique_ptr<EmulatorProcess>> launch_emulators(DaemonConfig& config) {
  std::vector<std::unique_ptr<EmulatorProcess>> out;
  const std::string exe =
      config.emulator_executable.empty() ? default_emulator_executable() : config.emulator_executable;
  // "{runtime_dir}" in emulator arguments and device values: the directory of the daemon's socket.
  const std::string runtime_dir = std::filesystem::path(config.socket_path).parent_path().string();
  auto expand = [&](std::string s) {
    for (auto pos = s.find("{runtime_dir}"); pos != std::string::npos; pos = s.find("{runtime_dir}", pos)) {
      s.replace(pos, 13, runtime_dir);
      pos += runtime_dir.size();
    }
    return s;
  };
  std::error_code ec;
  std::filesystem::create_directories(runtime_dir, ec);
  std::vector<const EmulatorProcess*> raw;
  for (EmulatorSpec spec : config.emulators) {
    for (auto& a : spec.args) a = expand(a);
    const bool has_machine = std::find(spec.args.begin(), spec.args.end(), "--machine") != spec.args.end();
    if (!config.emulator_machine.empty() && !has_machine) {
      spec.args.push_back("--machine");
      spec.args.push_back(config.emulator_machine);
    }
    try {
      out.push_back(std::make_unique<EmulatorProcess>(exe, spec));
    } catch (const std::runtime_error& e) {
      // Its arguments come from the configuration: a configuration error (exit 2), at its table's line.
      throw ConfigError(config.source, spec.line, "emulator \"" + spec.name + "\"", e.what());
    }
    raw.push_back(out.back().get());
  }
  if (toml::array* devices = config.root->get_as<toml::array>("device")) {
    std::size_t i = 0;
    for (toml::node& node : *devices) {
      if (toml::table* t = node.as_table()) {
        t->for_each([&](auto& value) {
          if constexpr (toml::is_string<decltype(value)>) {
            if (value.get().find("{runtime_dir}") != std::string::npos) value = expand(value.get());
          }
        });
        std::vector<std::string> serving =
            substitute_emulator_endpoints(*t, raw, config.source, "device[" + std::to_string(i) + "]");
        if (const auto* name = t->get_as<std::string>("name")) {
          for (auto& d : config.devices)
            if (d.name == name->get()) d.emulators = serving;
        }
      }
      ++i;
    }
  }
  return out;
}

std::string_view default_config_text() { return embedded_default; }

DaemonConfig default_config() { return parse_config(embedded_default, "<embedded default>"); }

}  // namespace guideway::daemon
