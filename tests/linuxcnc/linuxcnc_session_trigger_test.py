#!/usr/bin/python3
"""guidewayd's linuxcnc-hal device and [[session_trigger]], without LinuxCNC: guideway-linuxcnc-bridge reads a
stand-in for halsampler (its -t lines: the default columns, a period lost to an overrun, the session pin up
then down), guidewayd publishes every period and starts a DBB session when the pin rises and ends it when it
falls (end_after_s later); the DBB bus is guideway-emulate dbb's own program.

- the session begins on the rising pin and ends on the falling one (EVENT session_triggered, both);
- the device counts every period and the lost ones (driver counters periods, lost_periods; EVENT periods_lost);
- a trigger that names a channel the device does not have is refused at start with file, line and key.

usage: linuxcnc_session_trigger_test.py BUILD_DIR
"""
import json
import os
import subprocess
import sys
import tempfile
import time
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import process_support  # noqa: E402

BUILD = sys.argv.pop(1) if len(sys.argv) > 1 else "build"
GUIDEWAYD = os.path.join(BUILD, "daemon", "guidewayd")
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")
BRIDGE = os.path.join(BUILD, "drivers", "linuxcnc", "guideway-linuxcnc-bridge")
EMULATE = os.path.join(BUILD, "simulators", "emulators", "guideway-emulate")

COLUMNS = 15  # the bridge's default columns
SESSION = 11  # the session pin's place among them


def period(seq, session, x_mm=12.5):
    values = ["0.000000"] * COLUMNS
    values[3] = f"{x_mm:.6f}"  # x_cmd_mm
    values[SESSION] = str(session)
    return f"{seq} " + " ".join(values)


CONFIG = """
[daemon]
socket = "{d}/g.sock"
state_dir = "{d}/state"

[[emulator]]
name = "can"
instrument = "dbb"
args = ["--bus", "unix:{d}/can.sock", "--program", "standard", "--feed-mm-min", "20000", "--nodes", "1", "2", "3", "4"]

[[device]]
name = "dbb"
driver = "dbb-can"
bus = "emulator:can"
sync = "produce"
sync_rate_hz = 100.0
  [[device.encoder]]
  channel = "bar_length"
  node_id = 1
  offset_mm = 100.0
  resolution_nm = 100
  [[device.encoder]]
  channel = "x"
  node_id = 2
  resolution_nm = 100
  [[device.encoder]]
  channel = "y"
  node_id = 3
  resolution_nm = 100
  [[device.encoder]]
  channel = "z"
  node_id = 4
  resolution_nm = 100

[[device]]
name = "linuxcnc"
driver = "linuxcnc-hal"
socket = "{d}/bridge.sock"

[[session_trigger]]
device = "linuxcnc"
channel = "{channel}"
kind = "dbb"
session_device = "dbb"
end_after_s = {end_after_s}
options = {{ feed_mm_per_min = 20000 }}
"""


class SessionTrigger(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="gw-trigger-")
        self.d = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def cli(self, *args):
        return process_support.guideway_cli(GUIDEWAY, os.path.join(self.d, "g.sock"), *args)

    def config(self, channel="session", end_after_s=0.3):
        path = os.path.join(self.d, "g.toml")
        with open(path, "w") as f:
            f.write(CONFIG.format(d=self.d, channel=channel, end_after_s=end_after_s))
        return path

    def source(self):
        """The stand-in for halsampler: waits for the file `go`, then 300 periods with the pin down, an
        overrun losing 5, 1000 up, 300 down, at 1 kHz."""
        lines = [period(k, 0) for k in range(300)] + ["overrun"]
        lines += [period(k, 1) for k in range(305, 1305)] + [period(k, 0) for k in range(1305, 1605)]
        script = os.path.join(self.d, "periods.txt")
        with open(script, "w") as f:
            f.write("\n".join(lines) + "\n")
        go = os.path.join(self.d, "go")
        pace = ("import sys,time\n"
                f"lines = open({script!r}).read().splitlines()\n"
                "for i in range(0, len(lines), 10):\n"
                "    print('\\n'.join(lines[i:i + 10]), flush=True)\n"
                "    time.sleep(0.01)\n")
        return f"while [ ! -e {go} ]; do sleep 0.02; done; python3 -c \"{pace}\"", go

    def start_bridge_and_daemon(self, source, **config):
        """The bridge serving `source`'s periods and guidewayd reading it, both streaming; (bridge, socket)."""
        bridge = subprocess.Popen([BRIDGE, "--socket", os.path.join(self.d, "bridge.sock"), "--source", source],
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.addCleanup(lambda: bridge.poll() is None and bridge.kill())
        env = dict(os.environ, XDG_STATE_HOME=os.path.join(self.d, "xdg"))
        daemon = subprocess.Popen([GUIDEWAYD, "--config", self.config(**config)], stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, text=True, env=env)
        self.addCleanup(lambda: daemon.poll() is None and daemon.kill())
        sock = os.path.join(self.d, "g.sock")
        self.assertTrue(process_support.wait_for(lambda: os.path.exists(sock), 20), "guidewayd did not start")
        streaming = lambda: all(d["state"] == "streaming" for d in json.loads(self.cli("status", "--json"))["devices"])
        self.assertTrue(process_support.wait_for(streaming, 20), self.cli("status"))
        return bridge, sock

    def test_the_pin_begins_and_ends_the_session_and_every_period_is_counted(self):
        source, go = self.source()
        bridge, sock = self.start_bridge_and_daemon(source)
        events = subprocess.Popen([GUIDEWAY, "--socket", sock, "watch", "--class", "EVENT", "--json"],
                                  stdout=subprocess.PIPE, text=True)
        self.addCleanup(lambda: events.poll() is None and events.kill())
        time.sleep(0.3)
        open(go, "w").close()
        self.assertEqual(bridge.wait(timeout=30), 0)
        linuxcnc = lambda: [d for d in json.loads(self.cli("status", "--json"))["devices"] if d["name"] == "linuxcnc"][0]
        self.assertTrue(process_support.wait_for(lambda: linuxcnc()["driver_counters"]["periods"] == 1600, 10),
                        linuxcnc())
        counters = linuxcnc()["driver_counters"]
        self.assertEqual(counters["lost_periods"], 5, counters)
        self.assertEqual(counters["streams"], 1, counters)
        time.sleep(1.0)
        events.terminate()
        seen = [json.loads(line) for line in events.communicate(timeout=10)[0].splitlines() if line.startswith("{")]
        triggered = [e["reason"] for e in seen if e.get("event") == "session_triggered"]
        self.assertEqual(len(triggered), 2, seen)
        self.assertIn("linuxcnc.session rose: session dbb-dbb-", triggered[0])
        self.assertIn("linuxcnc.session fell: session dbb-dbb-", triggered[1])
        lost = [e["reason"] for e in seen if e.get("event") == "periods_lost"]
        self.assertEqual(lost, ["5 servo periods lost (halsampler overrun)"], seen)
        sessions = json.loads(self.cli("status", "--json"))["sessions"]
        self.assertEqual(len(sessions), 1, sessions)
        self.assertNotEqual(sessions[0]["state"], "running", sessions)

    def test_the_pin_rising_after_its_session_ended_begins_a_new_one(self):
        """A session that ended by itself (every pattern traced; here: stopped) while the trigger waits
        end_after_s after the pin fell: the pin's next rise begins a new session (LinuxCNC restarted with the
        tables and ran the test again before end_after_s had passed), not the old one going on."""
        go, go2 = os.path.join(self.d, "go"), os.path.join(self.d, "go2")
        first = [period(k, 0) for k in range(200)] + [period(k, 1) for k in range(200, 500)]
        first += [period(k, 0) for k in range(500, 700)]
        second = [period(k, 1) for k in range(700, 1000)] + [period(k, 0) for k in range(1000, 1200)]
        for name, lines in (("first.txt", first), ("second.txt", second)):
            with open(os.path.join(self.d, name), "w") as f:
                f.write("\n".join(lines) + "\n")
        pace = ("import os,sys,time\n"
                f"for name, gate in (({os.path.join(self.d, 'first.txt')!r}, {go!r}), "
                f"({os.path.join(self.d, 'second.txt')!r}, {go2!r})):\n"
                "    while not os.path.exists(gate): time.sleep(0.02)\n"
                "    lines = open(name).read().splitlines()\n"
                "    for i in range(0, len(lines), 10):\n"
                "        print('\\n'.join(lines[i:i + 10]), flush=True)\n"
                "        time.sleep(0.01)\n")
        bridge, _ = self.start_bridge_and_daemon(f"python3 -c \"{pace}\"", end_after_s=60)
        sessions = lambda: json.loads(self.cli("status", "--json"))["sessions"]
        open(go, "w").close()
        self.assertTrue(process_support.wait_for(lambda: len(sessions()) == 1, 20), sessions())
        linuxcnc = lambda: [d for d in json.loads(self.cli("status", "--json"))["devices"] if d["name"] == "linuxcnc"][0]
        self.assertTrue(process_support.wait_for(lambda: linuxcnc()["driver_counters"]["periods"] == 700, 20),
                        linuxcnc())
        self.cli("stop")  # ends as a session that traced its patterns does, 60 s before the trigger would
        self.assertTrue(process_support.wait_for(lambda: sessions()[0]["state"] not in ("running", "finishing"), 20),
                        sessions())
        open(go2, "w").close()
        self.assertTrue(process_support.wait_for(lambda: len(sessions()) == 2, 20),
                        f"the pin rose again but no new session began: {sessions()}")
        self.assertEqual(sessions()[-1]["state"], "running", sessions())
        self.assertEqual(bridge.wait(timeout=30), 0)

    def test_a_trigger_on_a_channel_the_device_lacks_is_refused_at_start(self):
        out = subprocess.run([GUIDEWAYD, "--config", self.config(channel="pin")], capture_output=True, text=True,
                             timeout=30)
        self.assertEqual(out.returncode, 2, out.stderr)
        self.assertRegex(out.stderr, r"g\.toml:\d+: session_trigger\[0\]\.channel: device \"linuxcnc\" has no "
                                     r"channel \"pin\" \(it has: x_cmd, y_cmd, z_cmd, session, period\)")


if __name__ == "__main__":
    process_support.run_unittests()
