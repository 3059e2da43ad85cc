// `guideway fleet ...`: the fleet view of a plant's machines (fleet/, docs/plant.md "guideway fleet").
//   status               one line per machine: state, age of the last DBB, latest headline figures
//   history MACHINE      every result of a machine, oldest first, each figure value ± u
//   report --out FILE    self-contained HTML: the fleet table and each machine's trends
//   ingest --topic T --file F   one message into the database, as `fleet serve` stores it (tests,
//                        importing results kept as files)
//   serve --broker URL   the fleet process: subscribes to the plant's broker and stores what arrives
//                        (fleet/subscriber), until SIGTERM or SIGINT
#include <atomic>
#include <chrono>
#include <csignal>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "core/atomic_file.hpp"
#include "core/csv_table.hpp"
#include "core/printable.hpp"
#include "core/utc_time.hpp"
#include "fleet/fleet_report.hpp"
#include "fleet/fleet_status.hpp"
#include "fleet/history.hpp"
#include "fleet/store.hpp"
#include "fleet/subscriber.hpp"
#include "plant/broker_address.hpp"
#include "plant/mqtt_socket.hpp"
#include "plant/topics.hpp"
#include "results/session_kinds.hpp"

namespace guideway::cli {

namespace {

double now_s() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

void add_db_option(CLI::App& cmd, std::string& db) {
  cmd.add_option("--db", db,
                 "fleet database (default: $GUIDEWAY_FLEET_DB, the service's /var/lib/guideway-fleet/fleet.sqlite, or "
                 "~/.local/state/guideway/fleet.sqlite)");
}

std::string db_path(const std::string& given) { return given.empty() ? fleet::default_database_path() : given; }

std::atomic<bool> stop_requested{false};

extern "C" void request_stop(int) { stop_requested.store(true); }

struct ServeOpts {
  std::string broker, ca_file, cert_file, key_file, username, password_file, client_id = "guideway-fleet";
  std::string topic_prefix = "guideway", db;
  std::uint32_t session_expiry_s = 7 * 24 * 3600;
  std::size_t max_message_kb = fleet::default_max_payload_bytes / 1024;
  void add(CLI::App& cmd) {
    cmd.add_option("--broker", broker, "mqtt://HOST[:PORT] or mqtts://HOST[:PORT]")->required();
    cmd.add_option("--ca-file", ca_file, "TLS: the CA certificate that signed the broker's (default: the system's)");
    cmd.add_option("--cert-file", cert_file, "TLS client certificate (with --key-file)");
    cmd.add_option("--key-file", key_file, "TLS client key");
    cmd.add_option("--username", username, "broker login");
    cmd.add_option("--password-file", password_file, "file whose first line is the password (mode 0600)");
    cmd.add_option("--client-id", client_id, "MQTT client id; the broker keeps this session")->capture_default_str();
    cmd.add_option("--topic-prefix", topic_prefix, "the daemons' topic_prefix")->capture_default_str();
    add_db_option(cmd, db);
    cmd.add_option("--session-expiry-s", session_expiry_s,
                   "how long the broker queues messages for the fleet while it is away")
        ->capture_default_str();
    cmd.add_option("--max-message-kb", max_message_kb,
                   "the largest payload stored; the broker is told never to send a larger one")
        ->capture_default_str()
        ->check(CLI::Range(1, 256 * 1024));
  }
};

// A TLS file option that names a file OpenSSL cannot use is refused now, not at the first connection.
void check_tls_file(const char* option, const std::string& path, plant::TlsFileRole role) {
  if (path.empty()) return;
  if (const std::string p = plant::tls_file_problem(path, role); !p.empty())
    throw std::runtime_error(std::string(option) + ": " + p);
}

void serve(const ServeOpts& o, CliContext& /*ctx*/) {
  fleet::SubscriberSettings s;
  try {
    s.connection.broker = plant::parse_broker_url(o.broker);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(std::string("--broker ") + e.what());
  }
  if (const std::string p = plant::topic_prefix_problem(o.topic_prefix); !p.empty())
    throw std::runtime_error("--topic-prefix \"" + o.topic_prefix + "\" " + p);
  if ((!o.ca_file.empty() || !o.cert_file.empty()) && !s.connection.broker.tls)
    throw std::runtime_error("--ca-file and --cert-file need an mqtts:// broker");
  if (!o.password_file.empty() && o.username.empty()) throw std::runtime_error("--password-file needs --username");
  if (o.cert_file.empty() != o.key_file.empty()) throw std::runtime_error("--cert-file and --key-file go together");
  check_tls_file("--ca-file", o.ca_file, plant::TlsFileRole::ca_certificates);
  check_tls_file("--cert-file", o.cert_file, plant::TlsFileRole::client_certificate);
  check_tls_file("--key-file", o.key_file, plant::TlsFileRole::private_key);
  if (const std::string p = plant::client_id_problem(o.client_id); !p.empty())
    throw std::runtime_error("--client-id " + p);
  s.connection.ca_file = o.ca_file;
  s.connection.cert_file = o.cert_file;
  s.connection.key_file = o.key_file;
  s.connection.username = o.username;
  if (!o.password_file.empty()) s.connection.password = plant::read_password_file(o.password_file);
  s.connection.client_id = o.client_id;
  s.connection.session_expiry_s = o.session_expiry_s;
  s.topic_prefix = o.topic_prefix;
  s.max_payload_bytes = o.max_message_kb * 1024;
  const std::string db = db_path(o.db);
  fleet::Store store(db);
  std::signal(SIGTERM, request_stop);
  std::signal(SIGINT, request_stop);
  const auto log = [](const std::string& line) { std::cerr << utc_now_iso() << " fleet: " << line << std::endl; };
  log("storing into " + db + "; broker " + s.connection.broker.url() + ", topics " +
      plant::subscription_filter(o.topic_prefix));
  fleet::Subscriber subscriber(std::move(s), store, log);
  subscriber.run(stop_requested);
  const auto& c = subscriber.counts();
  log("stopped: stored " + std::to_string(c.stored) + " message(s), " + std::to_string(c.duplicates) +
      " already stored, " + std::to_string(c.ignored) + " superseded, " + std::to_string(c.refused) + " refused");
}

struct StatusArgs {
  std::string db;
  bool json = false;
  void add(CLI::App& cmd) {
    add_db_option(cmd, db);
    cmd.add_flag("--json", json, "print one JSON object");
  }
};

void run_status(const StatusArgs& a, CliContext& /*ctx*/) {
  const fleet::Store store(db_path(a.db), fleet::Store::Open::existing);
  const auto status = fleet::fleet_status(store, now_s());
  if (a.json) {
    auto j = fleet::status_json(status);
    j["refused"] = fleet::refusals_json(store);
    std::cout << j.dump(1) << "\n";
  } else {
    std::cout << fleet::status_text(status) << fleet::refusals_text(store);
  }
}

struct HistoryArgs {
  std::string db, machine, kind;
  bool json = false;
  void add(CLI::App& cmd) {
    cmd.add_option("machine", machine, "machine name (as in its topics)")->required();
    cmd.add_option("--kind", kind, "only this session kind (" + results::session_kind_names() + ")");
    add_db_option(cmd, db);
    cmd.add_flag("--json", json, "print one JSON object");
  }
};

void run_history(const HistoryArgs& a, CliContext& /*ctx*/) {
  const fleet::Store store(db_path(a.db), fleet::Store::Open::existing);
  const auto machines = store.machines();
  if (std::none_of(machines.begin(), machines.end(), [&](const auto& m) { return m.machine == a.machine; })) {
    std::string known;
    for (const auto& m : machines) known += (known.empty() ? "" : ", ") + printable(m.machine);
    throw std::runtime_error("fleet history: unknown machine '" + printable(a.machine) +
                             "'; known: " + (known.empty() ? "none yet" : known));
  }
  const auto entries = fleet::history_of(store.results(a.machine, a.kind));
  if (a.json)
    std::cout << fleet::history_json(a.machine, entries).dump(1) << "\n";
  else
    std::cout << fleet::history_text(a.machine, entries);
}

struct ReportArgs {
  std::string db, out, title = "Guideway fleet";
  bool no_date = false;
  void add(CLI::App& cmd) {
    cmd.add_option("-o,--out", out, "HTML file to write ('-': standard output)")->required();
    add_db_option(cmd, db);
    cmd.add_option("--title", title, "page title");
    cmd.add_flag("--no-date", no_date, "leave the generation time out");
  }
};

void run_report(const ReportArgs& a, CliContext& /*ctx*/) {
  const fleet::Store store(db_path(a.db), fleet::Store::Open::existing);
  fleet::FleetReportOptions opt;
  opt.title = a.title;
  opt.now_s = now_s();
  if (!a.no_date) opt.subtitle = "Generated " + utc_now("%Y-%m-%d %H:%M UTC") + " by guideway fleet report";
  const std::string html = fleet::render_fleet_report(store, opt);
  if (a.out == "-") {
    std::cout << html;
    return;
  }
  write_file_atomically(a.out, html);
  std::cerr << "fleet report: " << store.machines().size() << " machine(s) -> " << a.out << " (" << html.size()
            << " bytes)\n";
}

struct IngestArgs {
  std::string db, topic, file, produced, received, prefix = "guideway";
  void add(CLI::App& cmd) {
    cmd.add_option("--topic", topic,
                   "its MQTT topic: PREFIX/MACHINE/params/KIND, .../explain/KIND, .../status, "
                   ".../event")
        ->required();
    cmd.add_option("--file", file, "the payload (a PARAMS, EXPLAIN, status or EVENT JSON object)")->required();
    cmd.add_option("--topic-prefix", prefix, "the daemons' topic_prefix (default guideway)");
    cmd.add_option("--produced-utc", produced, "when the daemon made it (ISO 8601 UTC); default: the receive time");
    cmd.add_option("--received-utc", received, "when it arrived (ISO 8601 UTC); default: now");
    add_db_option(cmd, db);
  }
};

void run_ingest(const IngestArgs& a, CliContext& /*ctx*/) {
  fleet::Store store(db_path(a.db));
  const std::string received = a.received.empty() ? utc_now_iso_ms() : a.received;
  const auto r = store.ingest(a.prefix, a.topic, read_text_file(a.file), a.produced, received);
  if (r.outcome == fleet::IngestResult::ignored || r.outcome == fleet::IngestResult::refused)
    throw std::runtime_error("fleet ingest: " + a.file + " " + std::string(fleet::to_string(r.outcome)) + ": " +
                             printable(r.reason));
  if (!r.reason.empty()) std::cerr << "fleet ingest: " << printable(r.reason) << "\n";
  std::cout << fleet::to_string(r.outcome) << "\n";
}

void add_fleet_commands(CLI::App& app, CliContext& ctx) {
  auto* fleet = shared_subcommand(app, "fleet",
                                  "the plant's machines as their daemons publish them over MQTT: "
                                  "status, history, report (docs/plant.md)");
  add_commands(
      *fleet, ctx,
      {command("status",
               "one line per machine: online/offline, age of the last DBB result, the latest headline "
               "figures (* moved beyond 2u) and what EXPLAIN found",
               &run_status),
       command("history",
               "every result of one machine, oldest first, each headline figure value ± u (* moved beyond "
               "2u against the one before)",
               &run_history),
       command("report",
               "write one self-contained HTML page: the fleet table and each machine's headline figures "
               "over time with ±2u bars",
               &run_report),
       command("ingest",
               "store one message as `fleet serve` does: a result, status or event kept as a file (import, "
               "tests)",
               &run_ingest),
       command("serve", "subscribe to the plant's broker and store every machine's results (runs until SIGTERM)",
               &serve)});
}

const CommandGroup group(&add_fleet_commands);

}  // namespace

}  // namespace guideway::cli
