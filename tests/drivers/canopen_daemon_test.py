#!/usr/bin/python3
"""guidewayd with three CANopen nodes written from the CiA 301 facts independently of Guideway
(tests/drivers/cia301_nodes.py: boot pre-operational, TPDO1 event-driven from the factory, no heartbeat) on its
Unix CAN bus. The daemon must check them by SDO, set their TPDO1 to synchronous and their heartbeat,
start them with NMT and stream; a node that reboots mid-session must be named in the device's state,
logged and started again, while the others keep streaming. (The situation the issue measured: nodes
waiting for NMT, and a daemon that said `streaming` with no sample.)
Usage: canopen_daemon_test.py BUILD_DIR"""
import json
import re
import os
import subprocess
import sys
import tempfile
import unittest
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from process_support import guideway_cli, wait_for  # noqa: E402

BUILD = sys.argv.pop(1) if len(sys.argv) > 1 else "build"
GUIDEWAYD = os.path.join(BUILD, "daemon", "guidewayd")
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")
NODES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "cia301_nodes.py")

CONFIG = """[daemon]
status_period_s = 0.2

[[device]]
name = "dbb"
driver = "dbb-can"
bus = "unix:{bus}"
sync = "produce"
sync_rate_hz = 100.0
timeout_ms = 300
configure_nodes = true
heartbeat_ms = 50
node_retry_ms = 200
  [[device.encoder]]
  channel = "bar_length"
  node_id = 1
  resolution_nm = 100
  offset_mm = 100.0
  serial_number = 4001
  [[device.encoder]]
  channel = "x"
  node_id = 2
  resolution_nm = 100
  serial_number = 4002
  product_code = 0x0406A001
  [[device.encoder]]
  channel = "y"
  node_id = 3
  resolution_nm = 100
  serial_number = 4003
"""


class CanopenNodesAndTheDaemon(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="gwc-")
        self.bus = os.path.join(self.tmp.name, "can.sock")
        self.sock = os.path.join(self.tmp.name, "g.sock")
        self.nodes = subprocess.Popen(["/usr/bin/python3", NODES, self.bus], stdin=subprocess.PIPE,
                                      stdout=subprocess.PIPE, text=True)
        self.addCleanup(self.stop, self.nodes)
        self.assertEqual(self.nodes.stdout.readline().strip(), "listening: " + self.bus)
        cfg = os.path.join(self.tmp.name, "g.toml")
        with open(cfg, "w") as f:
            f.write(CONFIG.format(bus=self.bus))
        env = dict(os.environ, XDG_STATE_HOME=os.path.join(self.tmp.name, "state"))
        env.pop("STATE_DIRECTORY", None)
        env.pop("NOTIFY_SOCKET", None)
        self.log = open(os.path.join(self.tmp.name, "guidewayd.log"), "w+")
        self.daemon = subprocess.Popen([GUIDEWAYD, "--config", cfg, "--socket", self.sock], env=env,
                                       stdout=subprocess.DEVNULL, stderr=self.log)
        self.addCleanup(self.stop, self.daemon)
        self.assertTrue(wait_for(lambda: os.path.exists(self.sock)), "daemon did not create its socket")

    def stop(self, p):
        if p.poll() is None:
            p.terminate()
            p.wait(timeout=10)
        if p is self.daemon:
            self.log.close()
        else:
            p.stdin.close()
            p.stdout.close()
        if p is self.nodes:
            self.tmp.cleanup()

    def dbb(self):
        return json.loads(guideway_cli(GUIDEWAY, self.sock, "status", "--json"))["devices"][0]

    def logged(self):
        self.log.flush()
        with open(self.log.name) as f:
            return f.read()

    def test_nodes_are_checked_configured_started_and_restarted_after_a_reboot(self):
        d = wait_for(lambda: (lambda d: d if d["state"] == "streaming" and d["counters"]["samples"] >= 50 else None)(
            self.dbb()), timeout=15)
        self.assertTrue(d, self.dbb())
        own = d["driver_counters"]
        self.assertGreaterEqual(own["nmt_starts"], 3)
        self.assertEqual(own["sdo_aborts"] + own["sdo_timeouts"], 0, own)
        log = self.logged()
        for n, channel, serial in ((1, "bar_length", 4001), (2, "x", 4002), (3, "y", 4003)):
            self.assertIn(f"node_checked: node {n} ({channel}): vendor-ID 0x00000123, product code 0x0406A001, "
                          f"revision 0x00030001, serial number {serial}; 100 nm per count; TPDO1 synchronous; "
                          f"heartbeat every 50 ms (TPDO1 transmission type was 254, set to 1 by Guideway, "
                          f"heartbeat time was 0 ms, set by Guideway); starting it", log)
        samples, starts = d["counters"]["samples"], own["nmt_starts"]

        self.nodes.stdin.write("reboot 3\n")
        self.nodes.stdin.flush()
        self.assertEqual(self.nodes.stdout.readline().strip(), "ok")
        # The device left `streaming` naming the node: read from the log, which has every state change (a
        # STATUS poll can miss a rebooted node that is checked and started again within one poll).
        named = wait_for(lambda: re.search(r"device dbb: \w+: node 3 \(y\)", self.logged()), timeout=10)
        self.assertTrue(named, "the device never named node 3:\n" + self.logged()[-2000:])
        back = wait_for(lambda: (lambda d: d if d["state"] == "streaming" and d["driver_counters"]["node_boot_ups"] == 1
                                 else None)(self.dbb()), timeout=10)
        self.assertTrue(back, self.dbb())
        self.assertGreater(back["driver_counters"]["nmt_starts"], starts, "node 3 was started again")
        self.assertGreater(back["counters"]["samples"], samples, "the others streamed on")
        self.assertTrue(wait_for(lambda: "node_back: node 3 (y)" in self.logged(), timeout=5), self.logged())
        self.assertIn("node_boot: node 3 (y) booted (boot-up message)", self.logged())
        self.assertIn('device dbb: lost: node 3 (y)', self.logged())


if __name__ == "__main__":
    unittest.main()
