#!/usr/bin/python3
"""A driver plugin in the running daemon: guidewayd loads the example C plugin from plugin_dir, lists it,
runs an example-ramp device whose samples, channels, state and own counters STATUS shows, and names each
broken plugin beside it in a warning and goes on.
Usage: driver_plugin_daemon_test.py BUILD_DIR PLUGIN_DIR BROKEN_PLUGIN_DIR"""
import json
import os
import signal
import subprocess
import sys
import tempfile
import unittest
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from process_support import wait_for  # noqa: E402

BUILD, PLUGINS, BROKEN = (sys.argv.pop(1) for _ in range(3)) if len(sys.argv) > 3 else ("build", "", "")
GUIDEWAYD = os.path.join(BUILD, "daemon", "guidewayd")
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")
RAMP = ['[[device]]', 'name = "ramp"', 'driver = "example-ramp"', 'count = 5', 'repeat = true', 'period_s = 0.01']


class DriverPluginDaemon(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="gwplug-")
        self.addCleanup(self.tmp.cleanup)
        # The good plugin and the two broken builds in one plugin directory.
        self.plugins = os.path.join(self.tmp.name, "plugins")
        os.mkdir(self.plugins)
        for d in (PLUGINS, BROKEN):
            for f in os.listdir(d):
                os.symlink(os.path.abspath(os.path.join(d, f)), os.path.join(self.plugins, f))
        self.sock = os.path.join(self.tmp.name, "g.sock")
        self.env = dict(os.environ, XDG_STATE_HOME=os.path.join(self.tmp.name, "state"))
        for k in ("STATE_DIRECTORY", "NOTIFY_SOCKET"):
            self.env.pop(k, None)

    def config(self, *lines):
        path = os.path.join(self.tmp.name, "guideway.toml")
        with open(path, "w") as f:
            f.write("\n".join(["[daemon]", f'plugin_dir = "{self.plugins}"', "", *lines, ""]))
        return path

    def assert_broken_plugins_named(self, stderr):
        self.assertIn("example_driver_plugin_no_entry.so: not a guideway driver plugin (no guideway_driver_plugin())",
                      stderr)
        self.assertIn("example_driver_plugin_other_abi.so: plugin ABI 99, guidewayd expects 1", stderr)

    def test_list_drivers_shows_the_plugin_and_names_the_broken_ones(self):
        out = subprocess.run([GUIDEWAYD, "--config", self.config(), "--list-drivers"], capture_output=True,
                             text=True, timeout=30, env=self.env)
        self.assertEqual(out.returncode, 0, out.stderr)
        names = [line.split("\t")[0] for line in out.stdout.splitlines()]
        self.assertEqual(names, ["dbb-can", "autocollimator-serial", "micrometer-modbus", "profilometer-tcp",
                                 "linuxcnc-hal", "example-ramp", "example-faulty"])
        self.assert_broken_plugins_named(out.stderr)

    def test_a_plugin_device_streams_in_the_daemon(self):
        p = subprocess.Popen([GUIDEWAYD, "--socket", self.sock, "--config", self.config(*RAMP)], env=self.env,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.addCleanup(lambda: p.poll() is None and p.kill())
        self.assertTrue(wait_for(lambda: os.path.exists(self.sock) or p.poll() is not None), "no socket")

        def device():
            out = subprocess.run([GUIDEWAY, "--socket", self.sock, "status", "--json"], capture_output=True,
                                 text=True, timeout=30)
            return json.loads(out.stdout or '{"devices": [{}]}')["devices"][0]
        self.assertTrue(wait_for(lambda: device().get("driver_counters", {}).get("ramps_completed", 0) >= 2, 20),
                        device())
        d = device()
        self.assertEqual((d["name"], d["driver"], d["state"]), ("ramp", "example-ramp", "streaming"))
        self.assertEqual(d["channels"], [{"name": "ramp", "unit": "m"}, {"name": "elapsed", "unit": "s"}])
        self.assertGreaterEqual(d["counters"]["samples"], 10)
        self.assertEqual(d["counters"]["frames"], d["counters"]["samples"])
        self.assertEqual(d["seq_gaps"], 0)
        p.send_signal(signal.SIGTERM)
        _, stderr = p.communicate(timeout=30)
        self.assertEqual(p.returncode, 0, stderr)
        self.assert_broken_plugins_named(stderr)

    def test_a_nested_table_is_a_configuration_error_naming_the_key(self):
        out = subprocess.run([GUIDEWAYD, "--config", self.config(*RAMP[:3], "count = { value = 5 }"), "--check-config"],
                             capture_output=True, text=True, timeout=30, env=self.env)
        self.assertEqual(out.returncode, 2, out.stderr)
        self.assertIn("guideway.toml:7: device[0].count: a plugin driver's setting is a string, a number or a boolean, "
                      "not a table", out.stderr)


if __name__ == "__main__":
    unittest.main()
