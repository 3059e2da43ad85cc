#!/usr/bin/python3
"""guidewayd on a controller PC whose kernel isolates a CPU for the CNC's real-time loop (isolcpus=):
none of the daemon's threads may run there, by default. The kernel's list
(/sys/devices/system/cpu/isolated) is stood in for by a file named in $GUIDEWAY_CPU_ISOLATED_FILE that
isolates this machine's last CPU. Then [daemon] cpu_affinity and nice, and their configuration errors.
Usage: cpu_placement_test.py BUILD_DIR"""
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import unittest
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "support"))
from process_support import run_unittests, wait_for  # noqa: E402

BUILD = sys.argv.pop(1) if len(sys.argv) > 1 else "build"
GUIDEWAYD = os.path.join(BUILD, "daemon", "guidewayd")
CPUS = sorted(os.sched_getaffinity(0))


def config(tmp, daemon_keys=""):
    return f"""
[daemon]
socket = "{tmp}/rt/guideway.sock"
state_dir = "{tmp}/state"
{daemon_keys}

[[emulator]]
name = "profiler"
instrument = "profilometer"
args = ["--port", "0", "--points-per-s", "2000"]

[[device]]
name = "profilometer"
driver = "profilometer-tcp"
host = "emulator:profiler:host"
port = "emulator:profiler:port"
"""


def status(path):
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.settimeout(5)
        s.connect(path)
        s.sendall(b'{"class":"status"}\n')
        buf = b""
        while True:
            buf += s.recv(65536)
            for line in buf.split(b"\n"):
                if line.startswith(b'{"class":"STATUS"'):
                    return json.loads(line)


def tasks(pid):
    """{tid: (name, Cpus_allowed_list, last CPU run on, nice)} of every thread of pid."""
    out = {}
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{tid}/stat") as f:
                stat = f.read()
            with open(f"/proc/{pid}/task/{tid}/status") as f:
                allowed = next(line.split(":", 1)[1].strip() for line in f if line.startswith("Cpus_allowed_list:"))
        except (OSError, StopIteration):
            continue
        name = stat[stat.index("(") + 1:stat.rindex(")")]
        fields = stat[stat.rindex(")") + 2:].split()  # from field 3 (state) on
        out[int(tid)] = (name, allowed, int(fields[36]), int(fields[16]))  # processor (39), nice (19)
    return out


class Daemon:
    def __init__(self, daemon_keys="", env=None):
        self.tmp = tempfile.mkdtemp(prefix="gw-cpu-")
        os.makedirs(f"{self.tmp}/rt")
        cfg = f"{self.tmp}/guideway.toml"
        with open(cfg, "w") as f:
            f.write(config(self.tmp, daemon_keys))
        self.socket = f"{self.tmp}/rt/guideway.sock"
        self.log = open(f"{self.tmp}/log", "w+")
        self.p = subprocess.Popen([GUIDEWAYD, "--config", cfg], stdout=self.log, stderr=subprocess.STDOUT,
                                  env={**os.environ, **(env or {})})
        ok = wait_for(lambda: os.path.exists(self.socket) and
                      all(d["state"] == "streaming" for d in status(self.socket)["devices"]), timeout=20)
        if not ok:
            self.stop()
            raise AssertionError("guidewayd did not stream:\n" + self.text())

    def text(self):
        self.log.seek(0)
        return self.log.read()

    def watch(self, seconds):
        """Every thread's placement, looked at every 5 ms for `seconds`: {tid: [(name, allowed, cpu, nice), ...]}."""
        seen = {}
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            for tid, t in tasks(self.p.pid).items():
                seen.setdefault(tid, []).append(t)
            time.sleep(0.005)
        return seen

    def stop(self):
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGTERM)
            self.p.wait(timeout=20)
        self.log.close()


@unittest.skipIf(len(CPUS) < 2, "needs two CPUs: one to isolate, one for the daemon")
class CpuPlacement(unittest.TestCase):
    def test_no_thread_ever_runs_on_an_isolated_cpu(self):
        isolated = CPUS[-1]
        with tempfile.NamedTemporaryFile("w", suffix=".isolated") as f:
            f.write(f"{isolated}\n")
            f.flush()
            d = Daemon(env={"GUIDEWAY_CPU_ISOLATED_FILE": f.name})
            try:
                seen = d.watch(1.5)
                log = d.text()
            finally:
                d.stop()
        names = {v[0][0] for v in seen.values()}
        self.assertIn("gw-io", names, "the I/O thread serves the devices")
        allowed = ",".join(str(c) for c in CPUS[:-1]) if len(CPUS) > 2 else str(CPUS[0])
        for tid, looks in seen.items():
            for name, cpus, cpu, _ in looks:
                self.assertNotEqual(cpu, isolated, f"thread {tid} ({name}) ran on the isolated CPU {isolated}")
                self.assertNotIn(str(isolated), cpus.replace("-", ",").split(","), f"{name} may run on {cpus}")
        self.assertIn(f"isolated: {isolated}", log)
        self.assertTrue(len(CPUS) > 2 or all(l[1] == allowed for v in seen.values() for l in v))

    def test_cpu_affinity_and_nice_apply_to_every_thread(self):
        d = Daemon(f'cpu_affinity = "{CPUS[0]}"\nnice = 7')
        try:
            seen = d.watch(0.5)
        finally:
            d.stop()
        self.assertGreaterEqual(len(seen), 3, "main, the I/O thread and helpers")
        for looks in seen.values():
            for name, cpus, cpu, nice in looks:
                self.assertEqual(cpus, str(CPUS[0]), name)
                self.assertEqual(cpu, CPUS[0], name)
                self.assertEqual(nice, 7, name)

    def test_configuration_errors_name_the_key(self):
        with tempfile.TemporaryDirectory(prefix="gw-cpu-") as tmp:
            for keys, words in (('cpu_affinity = "3-1"', "daemon.cpu_affinity: range \"3-1\" goes backwards"),
                                ('cpu_affinity = "a"', "daemon.cpu_affinity"),
                                ('cpu_affinity = ""', "names no CPU"),
                                ("nice = 30", "daemon.nice")):
                cfg = f"{tmp}/bad.toml"
                with open(cfg, "w") as f:
                    f.write(f'[daemon]\nsocket = "{tmp}/s.sock"\n{keys}\n')
                out = subprocess.run([GUIDEWAYD, "--config", cfg, "--check-config"], capture_output=True, text=True)
                self.assertEqual(out.returncode, 2, keys)
                self.assertIn(words, out.stderr, keys)
                self.assertIn("bad.toml:3", out.stderr, keys)


if __name__ == "__main__":
    run_unittests()
