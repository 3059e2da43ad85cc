// The dbb-can driver with CANopen nodes that behave as real ones (the emulator's canopen_node: boot
// pre-operational, PDOs only when operational, heartbeats, SDO), one test per node fault: a reboot,
// a heartbeat loss, an SDO abort, a node of the wrong identity, an EMCY, a TPDO1 not set to
// synchronous; and the controller managing NMT. For each: the other nodes keep streaming, the node
// is named in the state and in an event, the device recovers when the node comes back, and every
// cycle put on the bus is one sample (Bench::stop_and_check_all).
#include <gtest/gtest.h>

#include <algorithm>

#include "dbb_bench.hpp"
#include "driver_counters_support.hpp"
#include "test_support.hpp"

using namespace guideway;
using namespace std::chrono_literals;
using drivers::DeviceState;
using test::Bench;

namespace {

// Short periods, so each fault is seen and recovered from in well under a second.
void fast_canopen(drivers::dbb::DbbSettings& s) {
  s.network.heartbeat_ms = 20;
  s.network.configure_nodes = true;  // the emulator's nodes power on without heartbeat: written by SDO
  s.network.sdo_timeout_ms = 50;
  s.network.node_retry_ms = 100;
  s.nodes.assign(s.encoders.size(), {});
  for (auto& n : s.nodes) n.heartbeat_timeout_ms = 80;
}

struct NodeBench : Bench {
  explicit NodeBench(const test::TuneDriver& tune_driver = fast_canopen, const test::TuneEmulator& tune_emulator = {})
      : Bench(true, 200.0, 150, test::circle_source(), drivers::dbb::default_read_period_us, tune_driver,
              tune_emulator) {}

  std::vector<drivers::DeviceEvent> events;
  void collect() {
    for (auto& e : driver->take_events()) events.push_back(std::move(e));
  }
  // The first event of that name whose reason contains `text`, waiting for it.
  bool saw(const std::string& name, const std::string& text, std::chrono::milliseconds timeout = 5s) {
    return test::eventually(
        [&] {
          collect();
          return std::any_of(events.begin(), events.end(), [&](const auto& e) {
            return e.event == name && e.reason.find(text) != std::string::npos;
          });
        },
        timeout);
  }
  std::string events_text() {
    collect();
    std::string out;
    for (const auto& e : events) out += e.event + ": " + e.reason + "\n";
    return out;
  }
  bool state_is(DeviceState st, const std::string& text = "", std::chrono::milliseconds timeout = 5s) {
    return test::eventually(
        [&] {
          const auto s = driver->status();
          return s.state == st && s.reason.find(text) != std::string::npos;
        },
        timeout);
  }
  std::uint64_t counter(const std::string& name) { return test::driver_counters_by_name(driver->status()).at(name); }
  // Samples since `from` in which channel k was sent by its node (not held) and the others too.
  std::size_t complete_since(std::size_t from) {
    drain();
    std::size_t n = 0;
    for (std::size_t i = from; i < samples.size(); ++i) n += (samples[i].flags & sample_partial) == 0;
    return n;
  }
  // Partial samples since `from` in which every channel but `missing` is fresh (the others stream).
  std::size_t others_streaming_since(std::size_t from, std::size_t missing) {
    drain();
    std::size_t n = 0;
    for (std::size_t i = from + 1; i < samples.size(); ++i) {
      const bool partial = (samples[i].flags & sample_partial) != 0;
      bool others_move = true;
      for (std::size_t k = 0; k < 3; ++k) {
        if (k != missing && k != 0)
          others_move &= samples[i].value[k] != samples[i - 1].value[k];  // the bar: ~constant
      }
      const bool held = samples[i].value[missing] == samples[i - 1].value[missing] ||
                        (std::isnan(samples[i].value[missing]) && std::isnan(samples[i - 1].value[missing]));
      n += partial && others_move && held;
    }
    return n;
  }
};

}  // namespace

// The first finding: nodes that wait for NMT send nothing, and the device must say so rather
// than claim `streaming`. With nmt = "listen" and nobody starting them, no sample, and the state names
// every node as waiting; with the default (nmt = "start") they are checked, started and stream.
TEST(DbbNodes, PreOperationalNodesSendNothingUntilStartedAndTheDeviceSaysWhy) {
  {
    NodeBench b([](drivers::dbb::DbbSettings& s) {
      s.network.manage_nmt = false;
      s.network.sdo_checks = false;
    });
    ASSERT_TRUE(b.state_is(DeviceState::connecting, "node 1 (bar_length): pre-operational, waiting for the NMT master"))
        << b.driver->status().reason;
    std::this_thread::sleep_for(200ms);
    b.drain();
    EXPECT_EQ(b.samples.size(), 0u);
    const auto st = b.driver->status();
    EXPECT_EQ(st.state, DeviceState::connecting);
    EXPECT_NE(st.reason.find("node 3 (y)"), std::string::npos) << st.reason;
    EXPECT_EQ(b.counter("nmt_starts"), 0u);
    for (const auto s : b.emu.node_states()) EXPECT_EQ(s, drivers::can::NmtState::pre_operational);
  }
  NodeBench b;
  ASSERT_TRUE(b.wait_samples(50));
  ASSERT_TRUE(b.state_is(DeviceState::streaming)) << b.driver->status().reason;
  for (const auto s : b.emu.node_states()) EXPECT_EQ(s, drivers::can::NmtState::operational);
  EXPECT_GE(b.counter("nmt_starts"), 3u);
  EXPECT_TRUE(b.saw("node_checked",
                    "node 2 (x): vendor-ID 0x47570000, product code 0x00000196, revision 0x00010000, "
                    "serial number 1002; 100 nm per count; TPDO1 synchronous; heartbeat every 20 ms "
                    "(heartbeat time was 0 ms, set by Guideway); starting it"))
      << b.events_text();
  b.stop_and_check_all();
  // Started together once all were checked: no cycle lacks a node.
  EXPECT_EQ(std::count_if(b.samples.begin(), b.samples.end(), [](const Sample& s) { return s.flags & sample_partial; }),
            0);
}

TEST(DbbNodes, ARebootedNodeIsNamedCheckedAndStartedAgainWhileTheOthersStream) {
  NodeBench b;
  ASSERT_TRUE(b.wait_samples(20));
  ASSERT_TRUE(b.state_is(DeviceState::streaming));
  const std::size_t before = b.samples.size();
  // Counted from here: the nodes' own power-on boot-ups may have been heard too (they boot with the emulator).
  const auto boot_ups = b.counter("node_boot_ups");
  const auto starts = b.counter("nmt_starts");
  b.emu.inject_reboot(2, 0.15);
  ASSERT_TRUE(b.state_is(DeviceState::lost, "node 3 (y)")) << b.driver->status().reason;
  EXPECT_EQ(b.driver->status().reason.rfind("node 3 (y): ", 0), 0u) << b.driver->status().reason;
  ASSERT_TRUE(b.saw("node_boot", "node 3 (y) booted (boot-up message)")) << b.events_text();
  ASSERT_TRUE(b.state_is(DeviceState::streaming)) << b.driver->status().reason;
  ASSERT_TRUE(b.saw("node_back", "node 3 (y)")) << b.events_text();
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 10));
  EXPECT_GT(b.others_streaming_since(before, 2), 10u) << "bar and x kept streaming while y was off";
  EXPECT_EQ(b.counter("node_boot_ups") - boot_ups, 1u);
  EXPECT_GE(b.counter("nmt_starts") - starts, 1u);
  // The first complete sample after the reboot says a gap came before it.
  bool gap = false;
  for (std::size_t i = before; i < b.samples.size(); ++i) {
    if (!(b.samples[i].flags & sample_partial)) {
      if (i > before && (b.samples[i - 1].flags & sample_partial)) {
        gap = (b.samples[i].flags & sample_after_gap) != 0;
        break;
      }
    }
  }
  EXPECT_TRUE(gap);
  b.stop_and_check_all(5);
}

TEST(DbbNodes, AHeartbeatLossIsNamedAndTheNodeIsBackWhenItIs) {
  NodeBench b;
  ASSERT_TRUE(b.wait_samples(20));
  ASSERT_TRUE(b.state_is(DeviceState::streaming));
  const std::size_t before = b.samples.size();
  const auto boot_ups = b.counter("node_boot_ups");
  b.emu.inject_mute(1, 0.3);
  ASSERT_TRUE(b.state_is(DeviceState::lost, "node 2 (x): no heartbeat for 80 ms")) << b.driver->status().reason;
  ASSERT_TRUE(b.saw("node_lost", "node 2 (x): no heartbeat for 80 ms")) << b.events_text();
  // Back where it was (operational, a loose connector): its EMCY says it recovered, no restart needed.
  ASSERT_TRUE(b.saw("node_emcy", "node 2 (x): EMCY 0x8140 (recovered from bus off)")) << b.events_text();
  ASSERT_TRUE(b.state_is(DeviceState::streaming)) << b.driver->status().reason;
  ASSERT_TRUE(b.saw("node_back", "node 2 (x)")) << b.events_text();
  EXPECT_GT(b.others_streaming_since(before, 1), 10u);
  EXPECT_GE(b.counter("heartbeat_timeouts"), 1u);
  EXPECT_EQ(b.counter("node_boot_ups"), boot_ups) << "it did not reboot";
  EXPECT_EQ(b.counter("emcy"), 1u);
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 10));
  b.stop_and_check_all(5);
}

TEST(DbbNodes, ANodeThatAbortsSdoIsNamedInWordsNotStartedAndCheckedAgain) {
  NodeBench b;
  ASSERT_TRUE(b.wait_samples(20));
  const std::size_t before = b.samples.size();
  b.emu.inject_sdo_abort(1, 0x08000022);
  b.emu.inject_reboot(1, 0.02);  // the abort shows at its next check
  ASSERT_TRUE(
      b.state_is(DeviceState::error,
                 "node 2 (x): SDO upload of 0x1018:1 (identity: vendor-ID) aborted by the node: 0x08000022 data "
                 "cannot be transferred or stored to the application because of the present device state"))
      << b.driver->status().reason;
  ASSERT_TRUE(b.saw("node_check_failed", "node 2 (x): SDO upload of 0x1018:1")) << b.events_text();
  std::this_thread::sleep_for(250ms);  // checked again every 100 ms, refused each time
  EXPECT_EQ(b.emu.node_states()[1], drivers::can::NmtState::pre_operational) << "never started";
  EXPECT_GE(b.counter("sdo_aborts"), 2u);
  EXPECT_GT(b.others_streaming_since(before, 1), 10u);
  b.emu.inject_sdo_abort(1, 0);
  ASSERT_TRUE(b.state_is(DeviceState::streaming)) << b.driver->status().reason;
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 10));
  b.stop_and_check_all(5);
}

TEST(DbbNodes, ANodeOfTheWrongIdentityIsRefusedUntilTheRightOneIsThere) {
  NodeBench b(
      [](drivers::dbb::DbbSettings& s) {
        fast_canopen(s);
        s.nodes[1].serial_number = 1002;
        s.nodes[1].product_code = 406;
      },
      [](simulators::emulators::DbbEmulatorSettings& s) {
        s.identities.resize(3);
        s.identities[1].serial_number = 555;  // another encoder under node-ID 2
      });
  ASSERT_TRUE(b.state_is(DeviceState::error,
                         "node 2 (x): 0x1018:4 (identity: serial number) is 555, configured serial_number = 1002"))
      << b.driver->status().reason;
  ASSERT_TRUE(b.wait_samples(20)) << "bar and y stream without it";
  for (const Sample& s : b.samples) {
    EXPECT_TRUE(s.flags & sample_partial);
    EXPECT_TRUE(std::isnan(s.value[1])) << "x never answered";
    EXPECT_FALSE(std::isnan(s.value[2]));
  }
  EXPECT_EQ(b.emu.node_states()[1], drivers::can::NmtState::pre_operational);
  // The right encoder is fitted (it boots): checked, started, streaming.
  simulators::emulators::EncoderNodeIdentity right;
  right.serial_number = 1002;
  b.emu.inject_identity(1, right);
  b.emu.inject_reboot(1, 0.02);
  ASSERT_TRUE(b.state_is(DeviceState::streaming)) << b.driver->status().reason;
  ASSERT_TRUE(b.saw("node_checked",
                    "node 2 (x): vendor-ID 0x47570000, product code 0x00000196, revision 0x00010000, "
                    "serial number 1002"))
      << b.events_text();
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 10));
  b.stop_and_check_all(5);
}

TEST(DbbNodes, AnEmcyIsAnEventInWordsAndTheDeviceKeepsStreaming) {
  NodeBench b;
  ASSERT_TRUE(b.wait_samples(20));
  b.emu.inject_emcy(0, 0x4210, 0x09);
  ASSERT_TRUE(b.saw("node_emcy",
                    "node 1 (bar_length): EMCY 0x4210 (device temperature), error register 0x09 "
                    "(generic, temperature)"))
      << b.events_text();
  b.emu.inject_emcy(0, 0x0000, 0);
  ASSERT_TRUE(b.saw("node_emcy", "EMCY 0x0000 (error reset or no error)")) << b.events_text();
  const auto reset = std::find_if(b.events.begin(), b.events.end(),
                                  [](const auto& e) { return e.reason.find("0x0000") != std::string::npos; });
  EXPECT_FALSE(reset->warning);
  EXPECT_EQ(b.counter("emcy"), 2u);
  EXPECT_EQ(b.driver->status().state, DeviceState::streaming);
  b.stop_and_check_all();
}

// A TPDO1 that is event-driven (type 254) sends nothing on SYNC: refused with the object named, unless
// the configuration allows Guideway to write it, which it then verifies.
TEST(DbbNodes, TheTransmissionTypeIsVerifiedAndWrittenOnlyWhenAllowed) {
  const auto event_driven = [](simulators::emulators::DbbEmulatorSettings& s) { s.transmission_type = 254; };
  {
    NodeBench b(
        [](drivers::dbb::DbbSettings& s) {
          fast_canopen(s);
          s.network.heartbeat_ms = 0;
          s.network.configure_nodes = false;
        },
        event_driven);
    ASSERT_TRUE(b.state_is(DeviceState::error,
                           "node 1 (bar_length): 0x1800:2 (TPDO1 transmission type) is 254 (event-driven), needs 1 "
                           "(synchronous, every SYNC): set it on the node or allow configure_nodes = true"))
        << b.driver->status().reason;
    EXPECT_NE(b.driver->status().reason.find("node 3 (y): 0x1800:2"), std::string::npos);
    EXPECT_EQ(b.emu.node_states()[0], drivers::can::NmtState::pre_operational);
  }
  NodeBench b(fast_canopen, event_driven);
  ASSERT_TRUE(b.wait_samples(20));
  ASSERT_TRUE(b.state_is(DeviceState::streaming));
  EXPECT_TRUE(b.saw("node_checked", "TPDO1 transmission type was 254, set to 1 by Guideway")) << b.events_text();
  b.stop_and_check_all();
}

// The CNC controller is the NMT master (it started the nodes): Guideway sends no NMT command and no
// SDO request, only listens, and still follows boot-ups.
TEST(DbbNodes, WhenTheControllerManagesNmtGuidewayOnlyListens) {
  NodeBench b(
      [](drivers::dbb::DbbSettings& s) {
        s.network.manage_nmt = false;
        s.network.sdo_checks = false;
      },
      [](simulators::emulators::DbbEmulatorSettings& s) { s.nodes_start_operational = true; });
  ASSERT_TRUE(b.wait_samples(20));
  ASSERT_TRUE(b.state_is(DeviceState::streaming));
  b.emu.inject_reboot(0, 0.02);  // it starts itself again
  ASSERT_TRUE(b.saw("node_boot", "node 1 (bar_length) booted (boot-up message)")) << b.events_text();
  ASSERT_TRUE(b.state_is(DeviceState::streaming)) << b.driver->status().reason;
  EXPECT_EQ(b.counter("nmt_starts"), 0u);
  EXPECT_EQ(b.counter("sdo_timeouts") + b.counter("sdo_aborts"), 0u);
  ASSERT_TRUE(b.wait_samples(b.samples.size() + 10));
  b.stop_and_check_all();
}
