// The optional [mqtt] table of guidewayd's configuration (mqtt_config.hpp).
#include "daemon/mqtt_config.hpp"

#include <unistd.h>

#include <climits>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "core/input_file.hpp"
#include "core/printable.hpp"
#include "daemon/config.hpp"
#include "plant/broker_address.hpp"
#include "plant/mqtt_connection.hpp"
#include "plant/mqtt_socket.hpp"
#include "plant/topics.hpp"

namespace guideway::daemon {

namespace {

std::string host_name() {
  char name[HOST_NAME_MAX + 1] = {};
  if (gethostname(name, sizeof(name) - 1) != 0 || name[0] == '\0') return "localhost";
  std::string s(name);
  return s.substr(0, s.find('.'));  // the short name: "cell3-mill", not its domain
}

// A file the [mqtt] table names: relative to the configuration file, and readable now (checked here
// so that --check-config finds it, at its line).
std::string readable_file(const TableReader& t, const std::string& key, const std::string& relative_to) {
  const std::string value = t.get_string(key, "");
  if (value.empty()) return value;
  const std::filesystem::path path = config_relative_path(relative_to, value);
  try {  // a regular file (a FIFO would hang the daemon's start) that can be read now
    (void)read_file_head(path.string(), 0);
  } catch (const CsvError& e) {
    t.fail(key, e.what());
  }
  return std::filesystem::absolute(path).lexically_normal().string();
}

// A TLS file: readable, and holding what OpenSSL will need (a PEM certificate or key), so that a
// directory or a file of the wrong kind is a config error at its line, not "A TLS error occurred" later.
void check_tls_file(const TableReader& t, const std::string& key, const std::string& path, plant::TlsFileRole role) {
  if (path.empty()) return;
  if (const std::string p = plant::tls_file_problem(path, role); !p.empty()) t.fail(key, p);
}

}  // namespace

plant::PublisherSettings parse_mqtt_table(const TableReader& t, const std::string& relative_to) {
  plant::PublisherSettings s;
  try {
    s.connection.broker = plant::parse_broker_url(t.require_string("broker"));
  } catch (const std::invalid_argument& e) {
    t.fail("broker", e.what());
  }
  s.machine = t.get_string("machine", host_name());
  if (const std::string p = plant::topic_level_problem(s.machine); !p.empty())
    t.fail("machine", "\"" + printable(s.machine.substr(0, 64)) + "\" " + p);
  s.topic_prefix = t.get_string("topic_prefix", s.topic_prefix);
  if (const std::string p = plant::topic_prefix_problem(s.topic_prefix); !p.empty())
    t.fail("topic_prefix", "\"" + printable(s.topic_prefix.substr(0, 64)) + "\" " + p);
  s.connection.client_id = t.get_string("client_id", "guidewayd-" + s.machine);
  if (const std::string p = plant::client_id_problem(s.connection.client_id); !p.empty())
    t.fail("client_id", "\"" + printable(s.connection.client_id.substr(0, 64)) + "\" " + p);
  s.connection.keepalive_s = static_cast<int>(t.get_int("keepalive_s", 30, 5, 3600));
  s.connection.ca_file = readable_file(t, "ca_file", relative_to);
  s.connection.cert_file = readable_file(t, "cert_file", relative_to);
  s.connection.key_file = readable_file(t, "key_file", relative_to);
  const bool tls_key =
      !s.connection.ca_file.empty() || !s.connection.cert_file.empty() || !s.connection.key_file.empty();
  if (tls_key && !s.connection.broker.tls) {
    t.fail(!s.connection.ca_file.empty()     ? "ca_file"
           : !s.connection.cert_file.empty() ? "cert_file"
                                             : "key_file",
           "TLS files need an mqtts:// broker (it is " + s.connection.broker.url() + ")");
  }
  if (s.connection.cert_file.empty() != s.connection.key_file.empty())
    t.fail(s.connection.cert_file.empty() ? "key_file" : "cert_file",
           "a client certificate needs both cert_file and key_file");
  check_tls_file(t, "ca_file", s.connection.ca_file, plant::TlsFileRole::ca_certificates);
  check_tls_file(t, "cert_file", s.connection.cert_file, plant::TlsFileRole::client_certificate);
  check_tls_file(t, "key_file", s.connection.key_file, plant::TlsFileRole::private_key);
  s.connection.username = t.get_string("username", "");
  const std::string password_file = readable_file(t, "password_file", relative_to);
  if (!password_file.empty()) {
    if (s.connection.username.empty()) t.fail("password_file", "a password needs a username");
    try {
      s.connection.password = plant::read_password_file(password_file);
    } catch (const std::runtime_error& e) {
      t.fail("password_file", e.what());
    }
  }
  if (t.has("password")) t.fail("password", "never inline: put the password in a file and name it in password_file");
  s.queue_max_messages = static_cast<std::size_t>(t.get_int("queue_max_messages", 10000, 1, 10'000'000));
  s.queue_max_bytes = static_cast<std::size_t>(t.get_int("queue_max_mb", 64, 1, 1 << 20)) << 20;
  s.queue_events_percent = t.get_double("queue_events_percent", 25.0, 1.0, 100.0);
  s.events_per_minute = t.get_double("events_per_minute", 60.0, 1.0, 60000.0);
  s.reconnect_max_s = t.get_double("reconnect_max_s", 60.0, 1.0, 3600.0);
  s.release = GUIDEWAY_VERSION;
  t.reject_unknown_keys();
  return s;
}

}  // namespace guideway::daemon
