#pragma once
// The CANopen network management of a dbb-can bus (CiA 301 facts), pure: frames and time in,
// frames to send and events out, no I/O. For each configured encoder node it
//  - checks the node by SDO when the bus is connected and whenever the node boots: identity (0x1018),
//    resolution (CiA 406 linear measuring step 0x6005:1, nm), TPDO1 COB-ID and transmission type
//    (0x1800:1/2, written to 1 = synchronous every SYNC when configure_nodes allows), heartbeat
//    producer time (0x1017);
//  - starts it (NMT start remote node) once checked, unless the controller manages NMT;
//  - consumes its heartbeat (a per-node timeout), reads its boot-up message and its EMCYs;
//  - follows its PDOs: an operational node missing from `silent_after_cycles` cycles in a row, or
//    without a PDO for pdo_timeout_ms, is silent.
// health() sums the nodes up for the device state: `ok` only while every node delivers. Not thread
// safe (the driver thread owns it).

#include <linux/can.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "drivers/can/canopen.hpp"
#include "drivers/dbb/dbb_protocol.hpp"

namespace guideway::drivers::dbb {

// What a node must be, from its [[device.encoder]] table. Unset identity fields are read and
// reported, not compared.
struct NodeExpectation {
  std::optional<std::uint32_t> vendor_id;
  std::optional<std::uint32_t> product_code;
  std::optional<std::uint32_t> revision_number;
  std::optional<std::uint32_t> serial_number;
  // The instrument's serial ([[device]] serial, when a number) this node must report: a node that does
  // not is warned about (an EVENT and warnings()), never refused: its data are what was measured.
  std::optional<std::uint32_t> instrument_serial;
  bool check_resolution = true;           // compare 0x6005:1 (nm per count) with resolution_nm
  std::int64_t heartbeat_timeout_ms = 0;  // 0: this node's heartbeat is not monitored
};

struct NetworkSettings {
  bool manage_nmt = true;             // send NMT start (nmt = "start"); false: the controller manages NMT
  bool sdo_checks = true;             // check every node by SDO before starting it
  bool configure_nodes = false;       // write TPDO1's transmission type and the heartbeat time where they differ
  std::int64_t heartbeat_ms = 0;      // producer heartbeat time the nodes must have (0x1017); 0: not checked
  std::int64_t sdo_timeout_ms = 100;  // per SDO request (one retry before the node's check fails)
  std::int64_t node_retry_ms = 2000;  // a node whose check failed is checked again after this
  std::int64_t pdo_timeout_ms = 500;  // an operational node without a PDO this long is silent
  int silent_after_cycles = 3;        // ... or missing from this many emitted cycles in a row
};

// What the node said about itself (0x1018); fields the node does not have stay unset.
struct NodeIdentity {
  std::optional<std::uint32_t> vendor_id;
  std::optional<std::uint32_t> product_code;
  std::optional<std::uint32_t> revision_number;
  std::optional<std::uint32_t> serial_number;
};

// Something that happened on the network: `event` is a fixed name (node_checked, node_check_failed,
// node_boot, node_lost, node_back, node_emcy, instrument_serial_mismatch), `reason` names the node and
// says what.
struct NetworkEvent {
  std::string event;
  std::string reason;
  bool warning = true;
};

// The nodes summed up: the worst of them decides.
struct NetworkHealth {
  // failed: a node answered but is not what the configuration says (or refused the checks); lost: a
  // node does not answer, or stopped delivering.
  enum class Level { ok, starting, lost, failed };
  Level level = Level::starting;
  std::string reason;  // every node that is not ok, named, "; "-separated ("" when ok)
};

struct NetworkCounters {
  std::uint64_t boot_ups = 0;            // boot-up messages of configured nodes
  std::uint64_t heartbeat_timeouts = 0;  // a node's heartbeat missed its timeout
  std::uint64_t emcys = 0;               // EMCY messages of configured nodes
  std::uint64_t sdo_aborts = 0;          // SDO transfers the node aborted
  std::uint64_t sdo_timeouts = 0;        // SDO requests without an answer in time
  std::uint64_t nmt_starts = 0;          // NMT start commands sent
  std::uint64_t node_check_failures = 0;
};

class EncoderNetwork {
 public:
  enum class FrameUse { not_ours, used, bad };

  // `expect` has one entry per encoder (missing entries: defaults).
  EncoderNetwork(std::vector<EncoderScale> encoders, std::vector<NodeExpectation> expect, NetworkSettings settings);

  // A new connection to the bus at t_ns: whatever was known of the nodes is forgotten; they are checked
  // and started again.
  void connected(std::int64_t t_ns);
  // A received frame: NMT error control, EMCY and SDO responses of the configured nodes are used.
  FrameUse on_frame(const can_frame& frame, std::int64_t t_ns);
  // A cycle the decoder emitted: bit i of present_mask = encoder i's PDO was in it.
  void on_cycle(std::uint32_t present_mask, std::int64_t t_ns);
  // Time passes: SDO and heartbeat timeouts, PDO silence, checks to retry.
  void tick(std::int64_t t_ns);
  // When tick() has something to do next (INT64_MAX: nothing).
  [[nodiscard]] std::int64_t next_deadline() const noexcept;

  // Frames to put on the bus, in order, and events: the caller takes them (and clears the vectors).
  std::vector<can_frame>& outgoing() noexcept { return outgoing_; }
  std::vector<NetworkEvent>& events() noexcept { return events_; }
  // The next cycle follows a gap: a node came back (its first PDOs after a reboot or a silence).
  bool take_gap() noexcept {
    const bool g = gap_;
    gap_ = false;
    return g;
  }

  [[nodiscard]] const NetworkHealth& health();
  // Bumped whenever health() may have changed.
  [[nodiscard]] std::uint64_t health_version() const noexcept { return version_; }
  [[nodiscard]] const NetworkCounters& counters() const noexcept { return counters_; }
  // What stands whatever the health: a node whose serial is not the instrument's (kept until a check of
  // that node finds it right). A change bumps health_version().
  [[nodiscard]] std::vector<std::string> warnings() const;
  [[nodiscard]] const NodeIdentity& identity(std::size_t encoder) const { return nodes_.at(encoder).identity; }
  [[nodiscard]] std::size_t node_count() const noexcept { return nodes_.size(); }
  // "node 3 (y)"
  [[nodiscard]] std::string node_name(std::size_t encoder) const;

 private:
  enum class Phase { unknown, checking, failed, starting, operational, waiting, stopped };
  enum class Step {
    vendor,
    product,
    revision,
    serial,
    resolution,
    tpdo_cob_id,
    tx_type,
    tx_type_write,
    tx_type_verify,
    heartbeat,
    heartbeat_write,
    heartbeat_verify,
    done
  };
  struct Node {
    EncoderScale scale;
    NodeExpectation expect;
    Phase phase = Phase::unknown;
    Step step = Step::vendor;
    bool sdo_pending = false;
    int sdo_tries = 0;
    std::int64_t sdo_deadline_ns = 0;
    std::int64_t retry_at_ns = 0;    // failed: check again then
    std::int64_t started_at_ns = 0;  // NMT start sent then
    std::string failure;
    bool absent = false;  // the check failed because the node did not answer (lost, not refused)
    std::string configured;  // what this check wrote ("", or "TPDO1 transmission type set to 1")
    NodeIdentity identity;
    bool rebooted = false;  // the current check follows a boot-up message
    std::int64_t last_heartbeat_ns = 0;
    bool heartbeat_lost = false;
    std::int64_t last_pdo_ns = 0;
    int missed_cycles = 0;
    bool silent = false;
    std::string silent_why;
    bool was_down = false;  // lost, silent or rebooted: its next PDO is news (node_back)
    std::string instrument_warning;  // the last check's serial mismatch ("" = none)
  };

  void start_check(std::size_t i, std::int64_t t_ns);
  void send_step(std::size_t i, std::int64_t t_ns);
  void on_sdo(std::size_t i, const can::SdoMessage& m, std::int64_t t_ns);
  void step_done(std::size_t i, std::int64_t t_ns);
  // The check failed: the node is not started. `absent`: it did not answer at all (the device is lost,
  // not in error).
  void fail(std::size_t i, std::string why, std::int64_t t_ns, bool absent = false);
  void checked(std::size_t i, std::int64_t t_ns);
  // The node's serial against the instrument's (NodeExpectation::instrument_serial): warns, never fails.
  void compare_instrument_serial(std::size_t i);
  void start_nodes_ready(std::int64_t t_ns);
  void send_start(std::size_t i, std::int64_t t_ns);
  void on_heartbeat(std::size_t i, const can::Heartbeat& h, std::int64_t t_ns);
  void on_boot(std::size_t i, std::int64_t t_ns);
  void node_delivers(std::size_t i, std::int64_t t_ns);
  void mark_silent(std::size_t i, const std::string& why);
  void event(std::string name, std::string reason, bool warning = true);
  [[nodiscard]] int index_of(std::uint8_t node) const noexcept;
  [[nodiscard]] can::SdoAddress address_of(Step step) const noexcept;
  [[nodiscard]] std::int64_t heartbeat_timeout_ns(const Node& n) const noexcept;
  void changed() noexcept { ++version_; }

  NetworkSettings settings_;
  std::vector<Node> nodes_;
  bool first_round_ = true;  // checks since the connection: start the nodes together when all are done
  std::int64_t connected_ns_ = 0;
  std::vector<can_frame> outgoing_;
  std::vector<NetworkEvent> events_;
  bool gap_ = false;
  NetworkCounters counters_;
  std::uint64_t version_ = 1;
  std::uint64_t health_of_version_ = 0;
  NetworkHealth health_;
};

}  // namespace guideway::drivers::dbb
