#!/usr/bin/python3
"""The three-plane ballbar test live (slow: one pass of the emulated program takes about 70 s): guidewayd on
its embedded default with the DBB emulator running `--program three-plane` (xy 360 deg, xz and yz 220 deg
above the centre, ccw then cw each) on x, y and z encoders, `guideway start dbb --test three-plane --wait`,
and its PARAMS' planes and summary against config/machine-example.toml.

What a ballbar reads in a vertical plane is the file's squareness plus what its other errors add to the
plane's apparent squareness: the roll of Y (Lai's c0 = 200 urad at y = 0) tilts X in Z, and the cubic
straightness of X and Y in Z has a linear part over the arc, so squareness XZ reads about -93 urad where
the file says 20. So the live figures are held to the same test simulated offline on the machine file
(`guideway simulate dbb` + `identify dbb`), and the file's own vertical errors to the difference the
simulation shows with them taken out of the file: squareness XZ 20 and YZ -25 urad, Z scale 15 ppm (in
the scale mismatches XZ and YZ), and backlash Z 2 um directly (nothing else reads as it), from both
vertical planes in agreement. Absolute scales carry the servo lag's radial shrink (30 ms on every axis:
v^2 tau^2 / (2 r^2), -112 ppm at 3000 mm/min) on every axis alike; the mismatches do not.
Usage: e2e_three_plane_test.py BUILD_DIR (GUIDEWAY_TEST_KEEP_DIR=DIR: its temporary directory copied there)"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import unittest

BUILD = sys.argv.pop(1) if len(sys.argv) > 1 else "build"
GUIDEWAYD = os.path.join(BUILD, "daemon", "guidewayd")
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")
SOURCE = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
FEED_MM_PER_MIN = 3000


class ThreePlaneLive(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="gw3p-")
        self.addCleanup(self.tmp.cleanup)
        if os.environ.get("GUIDEWAY_TEST_KEEP_DIR"):  # the session, its recording and the files, to look at after
            self.addCleanup(shutil.copytree, self.tmp.name, os.environ["GUIDEWAY_TEST_KEEP_DIR"], dirs_exist_ok=True,
                           ignore=shutil.ignore_patterns("*.sock"))
        default = subprocess.run([GUIDEWAYD, "--print-default-config"], capture_output=True, text=True,
                                 check=True).stdout
        program = f'"--program", "three-plane", "--feed-mm-min", "{FEED_MM_PER_MIN}"'
        config_text = default.replace('"--program", "standard", "--feed-mm-min", "1000"', program)
        self.assertIn(program, config_text, "the default's DBB emulator no longer runs the standard test")
        config = os.path.join(self.tmp.name, "three-plane.toml")
        with open(config, "w") as f:
            f.write(config_text)
        self.sock = os.path.join(self.tmp.name, "g.sock")
        env = {**os.environ, "XDG_STATE_HOME": os.path.join(self.tmp.name, "state")}
        env.pop("NOTIFY_SOCKET", None)
        self.log = open(os.path.join(self.tmp.name, "guidewayd.log"), "w+")
        self.addCleanup(self.log.close)
        self.daemon = subprocess.Popen([GUIDEWAYD, "--config", config, "--socket", self.sock], env=env,
                                       stdout=self.log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        self.addCleanup(self.stop_daemon)
        deadline = time.monotonic() + 30
        while not os.path.exists(self.sock):
            self.assertLess(time.monotonic(), deadline, "guidewayd did not start")
            time.sleep(0.1)

    def stop_daemon(self):
        self.daemon.terminate()
        self.daemon.wait(timeout=20)

    def cli(self, *args, timeout=60):
        r = subprocess.run([GUIDEWAY, "--socket", self.sock, *args], capture_output=True, text=True, timeout=timeout)
        self.assertEqual(r.returncode, 0, r.stderr + r.stdout)
        return r.stdout

    def test_three_planes_recover_the_vertical_errors(self):
        out = self.cli("start", "dbb", "--test", "three-plane", "--set", f"feed_mm_per_min={FEED_MM_PER_MIN}",
                       "--wait", "--json", "--timeout", "400", timeout=450)
        params = json.loads(out.splitlines()[-1])
        self.assertEqual(params["test"], "three-plane")
        self.assertEqual(len(params["derived"]), 6)
        for plane in ("xy", "xz", "yz"):
            self.assertNotIn("error", params["planes"][plane], params["planes"][plane])
        s = params["summary"]
        live = {
            "squareness_xz_urad": s["squareness"]["squareness_xz_urad"],
            "squareness_yz_urad": s["squareness"]["squareness_yz_urad"],
            "scale_mismatch_xz_ppm": s["scale_mismatch"]["scale_mismatch_xz_ppm"],
            "scale_mismatch_yz_ppm": s["scale_mismatch"]["scale_mismatch_yz_ppm"],
        }
        with_errors = self.offline(os.path.join(SOURCE, "config", "machine-example.toml"))
        without = self.offline(self.without_vertical_errors())
        report, failures = [], []

        def check(what, value, u, truth, k=3.0):
            report.append(f"{what}: {value:.3f} +/- {u:.3f} (expected {truth:.3f})")
            if abs(value - truth) > k * u:
                failures.append(report[-1])

        for name, figure in live.items():
            ref = with_errors[name]
            check(f"live {name} against the same test simulated", figure["value"],
                  (figure["u"] ** 2 + ref["u"] ** 2) ** 0.5, ref["value"])
        file_part = {"squareness_xz_urad": 20.0, "squareness_yz_urad": -25.0,
                     # scale mismatch a - b: Z's 15 ppm lowers both
                     "scale_mismatch_xz_ppm": -15.0, "scale_mismatch_yz_ppm": -15.0}
        for name, truth in file_part.items():
            diff = live[name]["value"] - without[name]["value"]
            check(f"live {name} less the simulation without the file's vertical errors", diff,
                  (live[name]["u"] ** 2 + without[name]["u"] ** 2) ** 0.5, truth)
        check("squareness XY urad", s["squareness"]["squareness_xy_urad"]["value"],
              s["squareness"]["squareness_xy_urad"]["u"], 30.0)
        for axis, truth in (("x", 1.0), ("y", 2.0), ("z", 2.0)):
            b = s["backlash"][f"backlash_{axis}_um"]
            check(f"backlash {axis.upper()} um", b["value"], b["u"], truth, k=4.0)
        z = s["backlash"]["backlash_z_um"]
        self.assertEqual(sorted(f["plane"] for f in z["from"]), ["xz", "yz"])
        # Both vertical planes give Z's backlash, in agreement within 4 combined u. Not `consistent`, the
        # summary's 2 u flag: quietly the emulated session is the same every time, but under load which
        # samples arrive varies (3-15 % lost) and a 2 u test of honest figures fails one session in twenty.
        a, b = z["from"]
        self.assertLess(abs(a["value"] - b["value"]), 4 * (a["u"] ** 2 + b["u"] ** 2) ** 0.5, z)
        print("\n".join(report))
        if failures:  # what the identification fitted beside and noted, to tell a gappy session from the models
            for plane in ("xy", "xz", "yz"):
                print(plane, "beside:", params["planes"][plane].get("beside"), "notes:", params["planes"][plane].get("notes"))
        self.assertFalse(failures, "\n".join(failures))
        # The text form: every plane, then the machine across them.
        text = self.cli("params", "dbb")
        for line in ("plane xy:", "plane xz:", "plane yz:", "the machine across its planes"):
            self.assertIn(line, text)
        # Compensation from the three planes together: x/y/z tables and the three skews, each plane's G
        # smaller with them on the virtual machine.
        comp = os.path.join(self.tmp.name, "comp")
        r = subprocess.run([GUIDEWAY, "--socket", self.sock, "compensate", "dbb", "--latest", "--out-dir", comp,
                            "--verify", "--machine", os.path.join(SOURCE, "config", "machine-example.toml"),
                            "--json"], capture_output=True, text=True, timeout=300)
        self.assertEqual(r.returncode, 0, r.stderr)
        c = json.loads(r.stdout)
        self.assertEqual([p["plane"] for p in c["planes"]], ["xy", "xz", "yz"])
        for name in ("x.comp", "y.comp", "z.comp"):
            self.assertTrue(os.path.exists(os.path.join(comp, name)) or
                            os.path.exists(os.path.join(comp, name + ".do-not-load")), c["files"])
        v = c["verify"]
        why = json.dumps({"do_not_load": v["do_not_load"], "loadable": v["loadable"],
                          "planes": [{k: p.get(k) for k in ("plane", "g_before_um", "g_tables_um", "g_tables_skew_um",
                                                            "g_after_um", "g_less", "g_before_runs_um", "loadable",
                                                            "g_loadable_um")} for p in v["planes"]]}, indent=1)
        # What the planes together leave fit to load was traced on every plane: no run of it grows, and each
        # plane's largest G falls. (G with every file, refused ones too, may grow: under load a figure the
        # planes disagree on is not written, X's scale, and y.comp's scale, mostly the servo lag's shrink
        # every axis shares, then makes the XY circle an ellipse: y.comp is refused, rightly.)
        for p in v["planes"]:
            self.assertEqual(len(p["g_loadable_um"]), len(p["g_before_runs_um"]), why)
            for before, loadable in zip(p["g_before_runs_um"], p["g_loadable_um"]):
                self.assertLessEqual(loadable, before + 5e-4, p["plane"] + ": " + why)
            self.assertLess(max(p["g_loadable_um"]), max(p["g_before_runs_um"]), p["plane"] + ": " + why)

    def without_vertical_errors(self):
        """config/machine-example.toml without what only the vertical planes see of it."""
        with open(os.path.join(SOURCE, "config", "machine-example.toml")) as f:
            text = f.read()
        for old, new in (("xz_urad = 20 ", "xz_urad = 0 "), ("yz_urad = -25 ", "yz_urad = 0 "),
                         ("scale_ppm = 15 ", "scale_ppm = 0 "), ("backlash_um = 2.0\nservo", "backlash_um = 0\nservo")):
            self.assertIn(old, text)
            text = text.replace(old, new)
        path = os.path.join(self.tmp.name, "without-vertical-errors.toml")
        with open(path, "w") as f:
            f.write(text)
        return path

    def offline(self, machine):
        """The vertical planes of the test simulated on `machine` and identified offline: diagnostics by name."""
        out = {}
        for plane in ("xz", "yz"):
            files = []
            for direction, start in (("ccw", "-20"), ("cw", "200")):
                path = os.path.join(self.tmp.name, f"{os.path.basename(machine)}.{plane}.{direction}.csv")
                subprocess.run([GUIDEWAY, "simulate", "dbb", "--machine", machine, "--radius-mm", "100",
                                "--feed-mm-per-min", str(FEED_MM_PER_MIN), "--direction", direction, "--plane", plane,
                                "--start-deg", start, "--arc-deg", "220", "--overshoot-deg", "10",
                                "--sample-rate-hz", "250", "--out", path], check=True, capture_output=True)
                files.append(path)
            d = json.loads(self.cli("identify", "dbb", *files, "--json"))["diagnostics"]
            out[f"squareness_{plane}_urad"] = d["squareness_urad"]
            out[f"scale_mismatch_{plane}_ppm"] = d["scale_mismatch_ppm"]
        return out


if __name__ == "__main__":
    unittest.main(verbosity=2)
