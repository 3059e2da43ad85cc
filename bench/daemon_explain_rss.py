#!/usr/bin/env python3
"""guidewayd's memory across a DBB session's EXPLAIN (bench/README.md "EXPLAIN's footprint", issue 45 item 1).

Starts the real guidewayd on its emulated instruments (--emulator-machine, as scripts/demo.sh does) with its own
runtime and state directories, reads VmRSS and VmHWM of /proc/PID/status every 20 ms, runs the standard ballbar
session (`guideway start dbb --wait`: ccw and cw circles, r = 100 mm, 1000 mm/min) and waits for the session's
EXPLAIN (`guideway explain --latest --kind dbb`). Prints VmHWM before the session, VmHWM when its PARAMS came
(identification, checked by EXPLAIN), VmHWM after its EXPLAIN, and the samples the EXPLAIN had.

    bench/daemon_explain_rss.py BUILD_DIR [--machine config/machine-example.toml] [--memory-mb MB] [--set KEY=VALUE]

--set passes a session option to `guideway start dbb` (docs/protocol.md). The emulated ballbar follows the
session's feed and radius (guidewayd tells it when the session starts, docs/configuration.md `[[emulator]]`):
`--set feed_mm_per_min=500` gives 2 x ~18k samples.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def status_kb(pid):
    out = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, rest = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                out[key] = int(rest.split()[0])
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("build")
    ap.add_argument("--machine", default=os.path.join(ROOT, "config", "machine-example.toml"))
    ap.add_argument("--memory-mb", type=int, help="[explain] memory_mb of the daemon's config (default: none)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a session option of `guideway start dbb` (repeatable)")
    o = ap.parse_args()
    d = tempfile.mkdtemp(prefix="daemon_explain_rss_")
    env = dict(os.environ, XDG_RUNTIME_DIR=os.path.join(d, "run"), XDG_STATE_HOME=os.path.join(d, "state"))
    os.makedirs(env["XDG_RUNTIME_DIR"], mode=0o700)
    daemon = [os.path.join(o.build, "daemon", "guidewayd"), "--emulator-machine", o.machine]
    if o.memory_mb is not None:
        cfg = os.path.join(d, "explain.toml")
        with open(cfg, "w") as f:
            f.write(f"[explain]\nmemory_mb = {o.memory_mb}\n")
        daemon += ["--config", cfg]
    cli = os.path.join(o.build, "cli", "guideway")
    log = open(os.path.join(d, "guidewayd.log"), "w")
    p = subprocess.Popen(daemon, env=env, stdout=log, stderr=subprocess.STDOUT)
    peak = {"VmRSS": 0}
    stop = threading.Event()

    def sample():
        while not stop.is_set() and p.poll() is None:
            try:
                s = status_kb(p.pid)
                peak["VmRSS"] = max(peak["VmRSS"], s.get("VmRSS", 0))
            except OSError:
                return
            time.sleep(0.02)

    sampler = threading.Thread(target=sample)
    sampler.start()
    try:
        for _ in range(100):
            if subprocess.run([cli, "version"], env=env, capture_output=True).returncode == 0:
                break
            time.sleep(0.1)
        time.sleep(3)  # the emulated instruments connect
        before = status_kb(p.pid)
        t0 = time.time()
        start = [cli, "start", "dbb", "--wait", "--timeout", "600"]
        for kv in o.set:
            start += ["--set", kv]
        subprocess.run(start, env=env, check=True, stdout=subprocess.DEVNULL)
        at_params = status_kb(p.pid)
        report = None
        for _ in range(600):
            r = subprocess.run([cli, "explain", "--latest", "--kind", "dbb", "--json"], env=env, capture_output=True)
            if r.returncode == 0:
                report = json.loads(r.stdout)
                break
            time.sleep(0.2)
        time.sleep(1)
        after = status_kb(p.pid)
        cpu = open(f"/proc/{p.pid}/stat").read().split(")")[1].split()
        ticks = os.sysconf("SC_CLK_TCK")
        print(f"guidewayd {daemon[0]}; session {time.time() - t0:.0f} s; memory_mb "
              f"{o.memory_mb if o.memory_mb is not None else 'default'}; session options {' '.join(o.set) or 'default'}")
        print(f"VmHWM before the session {before['VmHWM'] / 1024:.1f} MB (VmRSS {before['VmRSS'] / 1024:.1f})")
        print(f"VmHWM at the session's PARAMS {at_params['VmHWM'] / 1024:.1f} MB")
        print(f"VmHWM after its EXPLAIN {after['VmHWM'] / 1024:.1f} MB (VmRSS {after['VmRSS'] / 1024:.1f}); "
              f"VmRSS sampled at most {peak['VmRSS'] / 1024:.1f} MB")
        print(f"guidewayd CPU {(int(cpu[11]) + int(cpu[12])) / ticks:.1f} s")
        if report is not None:
            r = report if "n" in report else next((v for v in report.values() if isinstance(v, dict) and "n" in v), {})
            print(f"EXPLAIN: {r.get('n', '?')} samples, {len(r.get('findings', []))} findings")
        else:
            print("no EXPLAIN came")
    finally:
        stop.set()
        p.terminate()
        p.wait(timeout=30)
        sampler.join()
    return 0


if __name__ == "__main__":
    sys.exit(main())
