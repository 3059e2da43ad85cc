#!/usr/bin/python3
"""The CAN and serial instruments end to end, as processes: `guideway-emulate dbb` (Unix CAN gateway)
and `guideway-emulate autocollimator` (pseudo-terminal, path printed on stdout) run beside guidewayd,
which has the dbb-can and autocollimator-serial drivers built in; faults are
injected through the emulators' stdin and `guideway status --json` must show them counted while both
devices keep streaming (and the daemon keeps running).
Usage: can_serial_process_test.py BUILD_DIR SOURCE_DIR"""
import json
import os
import socket
import struct
import signal
import subprocess
import sys
import tempfile
import time
import unittest
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
import process_support  # noqa: E402


def wait_for(predicate, timeout=15.0):
    return process_support.wait_for(predicate, timeout)


BUILD = sys.argv.pop(1) if len(sys.argv) > 1 else "build"
SOURCE = sys.argv.pop(1) if len(sys.argv) > 1 else "."
GUIDEWAYD = os.path.join(BUILD, "daemon", "guidewayd")
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")
EMULATE = os.path.join(BUILD, "simulators", "emulators", "guideway-emulate")


class CanSerialProcesses(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="gwcs-")
        self.addCleanup(self.tmp.cleanup)
        self.sock = os.path.join(self.tmp.name, "g.sock")
        self.can = os.path.join(self.tmp.name, "can.sock")
        self.tty = os.path.join(self.tmp.name, "ttyAC0")

    def spawn(self, *args):
        p = subprocess.Popen(list(args), stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, bufsize=1)

        def cleanup():
            if p.poll() is None:
                p.kill()
                p.wait()
            for stream in (p.stdin, p.stdout, p.stderr):
                try:
                    stream.close()
                except OSError:
                    pass
        self.addCleanup(cleanup)
        return p

    def control(self, emulator, command):
        emulator.stdin.write(command + "\n")
        emulator.stdin.flush()
        reply = emulator.stdout.readline().strip()
        self.assertTrue(reply.startswith("ok"), reply)

    def status(self):
        out = subprocess.run([GUIDEWAY, "--socket", self.sock, "status", "--json"], capture_output=True, text=True,
                             timeout=20)
        self.assertEqual(out.returncode, 0, out.stderr)
        return {d["name"]: d for d in json.loads(out.stdout)["devices"]}

    def test_emulators_daemon_and_faults(self):
        listed = subprocess.run([GUIDEWAYD, "--list-drivers"], capture_output=True, text=True, timeout=20).stdout
        self.assertIn("dbb-can", listed)
        self.assertIn("autocollimator-serial", listed)

        dbb = self.spawn(EMULATE, "dbb", "--bus", "unix:" + self.can, "--feed-mm-min", "2000")
        self.assertEqual(dbb.stdout.readline().strip(), "bus: unix:" + self.can)
        self.assertEqual(dbb.stdout.readline().strip(), "endpoint: unix:" + self.can)
        ac = self.spawn(EMULATE, "autocollimator", "--link", self.tty, "--dwell-s", "0.2", "--step-mm", "25")
        first = ac.stdout.readline().strip()
        self.assertTrue(first.startswith("pty: /dev/pts/"), first)
        self.assertEqual(ac.stdout.readline().strip(), "link: " + self.tty)
        self.assertEqual(ac.stdout.readline().strip(), "endpoint: pty:" + self.tty)
        self.assertEqual(os.path.realpath(self.tty), first[len("pty: "):])

        with open(os.path.join(SOURCE, "config", "devices-can-serial.example.toml")) as f:
            text = f.read()
        text = text.replace("/tmp/guideway-can.sock", self.can).replace("/tmp/guideway-ac0", self.tty)
        text = text.replace('mode = "poll"', 'mode = "stream"')
        text = text.replace("[daemon]\n", "[daemon]\nstatus_period_s = 0.2\n", 1).replace(
            "status_period_s = 1.0\n", "", 1)
        cfg = os.path.join(self.tmp.name, "g.toml")
        with open(cfg, "w") as f:
            f.write(text)
        check = subprocess.run([GUIDEWAYD, "--config", cfg, "--check-config"], capture_output=True, text=True,
                               timeout=20)
        self.assertEqual(check.returncode, 0, check.stderr)
        d = self.spawn(GUIDEWAYD, "--config", cfg, "--socket", self.sock)
        self.assertTrue(wait_for(lambda: os.path.exists(self.sock)), "daemon did not create its socket")

        def streaming_with(n):
            s = self.status()
            ok = all(s[k]["state"] == "streaming" and s[k]["counters"]["samples"] >= n for k in ("dbb", "autocollimator"))
            return s if ok else None

        s = wait_for(lambda: streaming_with(50))
        self.assertTrue(s, self.status())
        self.assertEqual([c["name"] for c in s["dbb"]["channels"]], ["bar_length", "x", "y"])
        self.assertEqual([c["unit"] for c in s["autocollimator"]["channels"]], ["rad", "rad"])

        # Faults on both buses, while the daemon keeps running.
        self.control(dbb, "truncated 3")
        self.control(dbb, "bad 2")
        self.control(dbb, "error-frames 2")
        self.control(ac, "garbage 100")
        self.control(ac, "bad-checksum 2")
        s = wait_for(lambda: (lambda s: s if s["dbb"]["counters"]["bad_frames"] >= 7 and
                              s["autocollimator"]["counters"]["bad_frames"] >= 3 else None)(self.status()))
        self.assertTrue(s, self.status())
        # The two CAN error frames are bad frames and, by name, the dbb driver's error_frames; a Unix
        # gateway never drops a frame. The autocollimator driver keeps no counters of its own.
        s = wait_for(lambda: (lambda s: s if s["dbb"]["driver_counters"]["error_frames"] == 2 else None)(self.status()))
        self.assertTrue(s, self.status()["dbb"])
        self.assertEqual(s["dbb"]["driver_counters"]["dropped_frames"], 0, s["dbb"])
        self.assertEqual(s["autocollimator"]["driver_counters"], {}, s["autocollimator"])

        before = self.status()
        self.control(dbb, "disconnect")
        self.control(ac, "disconnect 0.3")
        s = wait_for(lambda: (lambda s: s if s["dbb"]["counters"]["reconnects"] >= 1 and
                              s["autocollimator"]["counters"]["reconnects"] >= 1 and
                              s["dbb"]["state"] == "streaming" and s["autocollimator"]["state"] == "streaming"
                              else None)(self.status()))
        self.assertTrue(s, self.status())
        self.assertTrue(ac.stdout.readline().strip().startswith("pty: /dev/pts/"))
        after = wait_for(lambda: (lambda s: s if all(
            s[k]["counters"]["samples"] > before[k]["counters"]["samples"] + 20 for k in ("dbb", "autocollimator"))
            else None)(self.status()))
        self.assertTrue(after, "samples keep coming after the reconnects")

        # The DBB emulator goes away for good: its device is lost, the autocollimator is unaffected.
        self.control(dbb, "quit")
        dbb.wait(timeout=10)
        s = wait_for(lambda: (lambda s: s if s["dbb"]["state"] != "streaming" else None)(self.status()))
        self.assertTrue(s)
        n = s["autocollimator"]["counters"]["samples"]
        self.assertTrue(wait_for(lambda: self.status()["autocollimator"]["counters"]["samples"] > n + 10))
        self.assertEqual(self.status()["autocollimator"]["state"], "streaming")

        d.send_signal(signal.SIGTERM)
        self.assertEqual(d.wait(timeout=10), 0)
        self.control(ac, "quit")
        self.assertEqual(ac.wait(timeout=10), 0)


    INSTRUMENT_CONFIG = """[daemon]
status_period_s = 0.2
state_dir = "{state}"
{refuse}
[[device]]
name = "dbb"
driver = "dbb-can"
bus = "unix:{bus}"
sync_rate_hz = 250.0
configure_nodes = true
heartbeat_ms = 100
serial = "1001"
calibration_certificate = "C-2023-117"
calibrated_on = 2023-01-10
calibration_due = 2024-01-10
calibrated_length_mm = 20.0
calibrated_length_u_um = 0.5
  [[device.encoder]]
  channel = "bar_length"
  node_id = 1
  resolution_nm = 100
  [[device.encoder]]
  channel = "x"
  node_id = 2
  resolution_nm = 100
  [[device.encoder]]
  channel = "y"
  node_id = 3
  resolution_nm = 100
"""

    def test_instrument_identity_expired_calibration_and_refusal(self):
        """Issue 30, part 4, through guidewayd and the emulated bar: a serial the bar's node does not report
        and a calibration past due are warned about (check-config, STATUS, start, PARAMS, recording, report),
        not refused; with refuse_uncalibrated the start is refused."""
        # The bar's node reports serial number 4242; the configuration says 1001. One 20 mm circle at
        # 6000 mm/min takes about 1.6 s.
        dbb = self.spawn(EMULATE, "dbb", "--bus", "unix:" + self.can, "--serial-numbers", "4242", "1002", "1003",
                         "--radius-mm", "20", "--feed-mm-min", "6000", "--pause-s", "0.2")
        self.assertEqual(dbb.stdout.readline().strip(), "bus: unix:" + self.can)
        self.assertEqual(dbb.stdout.readline().strip(), "endpoint: unix:" + self.can)
        state = os.path.join(self.tmp.name, "state")
        cfg = os.path.join(self.tmp.name, "g.toml")

        def write_config(refuse):
            with open(cfg, "w") as f:
                f.write(self.INSTRUMENT_CONFIG.format(state=state, bus=self.can,
                                                      refuse="refuse_uncalibrated = true" if refuse else ""))

        write_config(False)
        expired = "device dbb (serial 1001, certificate C-2023-117): calibration was due 2024-01-10, "
        check = subprocess.run([GUIDEWAYD, "--config", cfg, "--check-config"], capture_output=True, text=True,
                               timeout=20)
        self.assertEqual(check.returncode, 0, check.stderr)
        self.assertIn("warning: " + expired, check.stdout)
        d = self.spawn(GUIDEWAYD, "--config", cfg, "--socket", self.sock)
        self.assertTrue(wait_for(lambda: os.path.exists(self.sock)), "daemon did not create its socket")
        mismatch = ("node 1 (bar_length) reports serial number 4242 (0x1018:4), the device's serial is 1001: not "
                    "the instrument the configuration and its calibration name")
        s = wait_for(lambda: (lambda dev: dev if dev["state"] == "streaming" and len(dev.get("warnings", [])) == 2
                              else None)(self.status()["dbb"]))
        self.assertTrue(s, self.status()["dbb"])
        self.assertTrue(s["warnings"][0].startswith(expired), s["warnings"])
        self.assertEqual(s["warnings"][1], mismatch)
        self.assertEqual(s["instrument"]["serial"], "1001")
        self.assertTrue(s["instrument"]["calibration_expired"])
        text = subprocess.run([GUIDEWAY, "--socket", self.sock, "status"], capture_output=True, text=True,
                              timeout=20).stdout
        self.assertIn("instrument: serial 1001, certificate C-2023-117, calibrated 2023-01-10, due 2024-01-10, "
                      "bar 20.0000 mm (u 0.5 um)", text)
        self.assertIn("WARNING: " + expired, text)
        self.assertIn("WARNING: " + mismatch, text)

        # A session runs on it, and says so: the start's reply, the PARAMS, the recording, the report.
        out = subprocess.run([GUIDEWAY, "--socket", self.sock, "start", "dbb", "--set",
                              'patterns=[{"radius_mm":20,"height_mm":0,"direction":"ccw"}]', "--set",
                              "feed_mm_per_min=0", "--wait",
                              "--timeout", "30"], capture_output=True, text=True, timeout=40)
        self.assertEqual(out.returncode, 0, out.stderr + out.stdout)
        lines = out.stdout.splitlines()
        self.assertTrue(lines[1].startswith("WARNING: " + expired), lines[:3])
        self.assertIn("instrument: serial 1001, certificate C-2023-117, calibrated 2023-01-10, due 2024-01-10, "
                      "bar 20.0000 mm (u 0.5 um)", lines)
        self.assertTrue(lines[-1].startswith("WARNING: " + expired), lines[-3:])
        params = json.loads(subprocess.run([GUIDEWAY, "--socket", self.sock, "params", "dbb", "--json"],
                                           capture_output=True, text=True, timeout=20).stdout)
        self.assertTrue(params["instrument"]["calibration_expired"], params.get("instrument"))
        self.assertTrue(params["instrument"]["warning"].startswith(expired))
        with open(params["recording"]) as f:
            header = f.read(4096)
        for key in ("# instrument_serial = 1001", "# instrument_calibration_due = 2024-01-10",
                    "# instrument_calibrated_length_u_um = 0.5"):
            self.assertIn(key, header)
        report = params["recording"][:-len(".csv")] + ".report.html"
        self.assertTrue(wait_for(lambda: os.path.exists(report), timeout=10), report)
        with open(report) as f:
            html = f.read()
        self.assertIn("<h2>Instruments</h2>", html)
        self.assertIn("<strong>EXPIRED</strong>", html)
        self.assertIn("Warning: " + expired, html)
        d.send_signal(signal.SIGTERM)
        self.assertEqual(d.wait(timeout=10), 0)

        # refuse_uncalibrated: the same start is refused, naming the instrument and why.
        write_config(True)
        d = self.spawn(GUIDEWAYD, "--config", cfg, "--socket", self.sock)
        self.assertTrue(wait_for(lambda: os.path.exists(self.sock)), "daemon did not create its socket")
        out = subprocess.run([GUIDEWAY, "--socket", self.sock, "start", "dbb"], capture_output=True, text=True,
                             timeout=20)
        self.assertNotEqual(out.returncode, 0, out.stdout)
        self.assertIn(expired, out.stderr)
        self.assertIn("refused: [daemon] refuse_uncalibrated = true", out.stderr)
        warning = self.status()["dbb"]["warnings"][0]
        self.assertTrue(warning.startswith(expired) and warning.endswith(
            "; its sessions are refused (refuse_uncalibrated)"), warning)
        d.send_signal(signal.SIGTERM)
        self.assertEqual(d.wait(timeout=10), 0)

    def test_dbb_emulator_on_an_inherited_fd_speaks_the_documented_frames(self):
        # Python packs struct can_frame itself (id u32, dlc u8, 3 pad, 8 data): an independent check
        # of the wire format of docs/protocols.md.
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self.addCleanup(ours.close)
        p = subprocess.Popen([EMULATE, "dbb", "--fd", str(theirs.fileno()), "--nodes", "4", "5", "6",
                              "--resolution-nm", "50"], pass_fds=[theirs.fileno()], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        theirs.close()
        self.addCleanup(lambda: (p.poll() is None and p.kill(), p.wait(), p.stdin.close(), p.stdout.close(),
                                 p.stderr.close()))
        self.assertTrue(p.stdout.readline().startswith("bus: fd "))
        self.assertTrue(p.stdout.readline().startswith("endpoint: fd:"))
        ours.settimeout(5)
        frame = struct.Struct("<IB3x8s")
        # CiA 301: each node powers on with its boot-up message (0x700 + node, one byte 00) and stays
        # pre-operational: a SYNC gets no PDO until NMT "start remote node".
        boot = [frame.unpack(ours.recv(64)) for _ in range(3)]
        self.assertEqual(sorted((f[0], f[1], f[2][0]) for f in boot), [(0x704, 1, 0), (0x705, 1, 0), (0x706, 1, 0)])
        ours.send(frame.pack(0x080, 0, bytes(8)))
        # The bus gives a SYNC back to the one that sent it, before any answer (as SocketCAN's
        # CAN_RAW_RECV_OWN_MSGS): the cycle's boundary among the PDOs.
        self.assertEqual(frame.unpack(ours.recv(64))[:2], (0x080, 0), "the SYNC's echo")
        # Its SDO server: the serial number (0x1018:4, expedited upload 0x40 -> 0x43 + 4 bytes) and the
        # resolution in nm (0x6005:1); an object it does not have is aborted with 0x06020000.
        for request, answer in (((0x40, 0x18, 0x10, 0x04), (0x43, 0x18, 0x10, 0x04, 1004)),
                                ((0x40, 0x05, 0x60, 0x01), (0x43, 0x05, 0x60, 0x01, 50)),
                                ((0x40, 0x00, 0x20, 0x00), (0x80, 0x00, 0x20, 0x00, 0x06020000))):
            ours.send(frame.pack(0x604, 8, bytes(request) + bytes(4)))
            can_id, dlc, data = frame.unpack(ours.recv(64))
            self.assertEqual((can_id, dlc), (0x584, 8), "no PDO answered the SYNC before: only this SDO answer")
            self.assertEqual(tuple(data[:4]) + struct.unpack("<I", data[4:]), answer)
        ours.send(frame.pack(0x000, 2, bytes([0x01, 0x00]) + bytes(6)))  # start every node
        time.sleep(0.05)
        previous = None
        for cycle in range(20):
            ours.send(struct.pack("<IB3x8s", 0x080, 0, bytes(8)))
            self.assertEqual(struct.unpack("<IB3x8s", ours.recv(64))[0], 0x080, "the SYNC's echo first")
            frames = [struct.unpack("<IB3x8s", ours.recv(64)) for _ in range(3)]
            self.assertEqual([f[0] for f in frames], [0x184, 0x185, 0x186])
            self.assertEqual([f[1] for f in frames], [4, 4, 4])
            counts = [struct.unpack("<i", f[2][:4])[0] for f in frames]
            bar_m = 0.1 + counts[0] * 50e-9  # nominal 100 mm + counts * resolution
            self.assertAlmostEqual(bar_m, 0.1, delta=1e-3)  # the demo machine's errors are micrometres
            if previous is not None:
                self.assertLess(abs(counts[1] - previous[1]), 200000)  # 10 mm between cycles at most
            previous = counts
            time.sleep(0.01)
        p.stdin.write("quit\n")
        p.stdin.flush()
        self.assertEqual(p.wait(timeout=10), 0)

    def test_ports_lists_serial_ports(self):
        out = subprocess.run([GUIDEWAY, "ports", "--json"], capture_output=True, text=True, timeout=20)
        self.assertEqual(out.returncode, 0, out.stderr)
        for line in out.stdout.splitlines():
            port = json.loads(line)
            self.assertEqual(port["class"], "PORT")
            self.assertTrue(port["name"].startswith("/dev/"), port)
            if port["transport"] == "usb":
                self.assertRegex(port["usb_vid"], "^[0-9a-f]{4}$")
        table = subprocess.run([GUIDEWAY, "ports"], capture_output=True, text=True, timeout=20)
        self.assertEqual(table.returncode, 0, table.stderr)
        self.assertTrue(table.stdout.startswith("PORT") or table.stdout.startswith("no serial ports"), table.stdout)


if __name__ == "__main__":
    unittest.main(verbosity=2)
