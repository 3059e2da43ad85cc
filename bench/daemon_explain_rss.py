#!/usr/bin/env python3
"""guidewayd's memory across a DBB session's EXPLAIN (bench/README.md "EXPLAIN's footprint", issue 45 item 1).

Starts the real guidewayd on its emulated instruments (--emulator-machine, as scripts/demo.sh does) with its own
runtime and state directories, reads VmRSS and VmHWM of /proc/PID/status every 20 ms, runs the standard ballbar
session (`guideway start dbb --wait`: ccw and cw circles, r = 100 mm, 1000 mm/min) and waits for the session's
EXPLAIN (`guideway explain --latest --kind dbb`). Prints VmHWM before the session, VmHWM when its PARAMS came
(identification, checked by EXPLAIN), VmHWM after its EXPLAIN, and the samples the EXPLAIN had; and, where the
daemon analyses the session in a process of its own (`guidewayd --analyse-session`, [daemon] session_analysis),
that process's VmHWM and the most the two held together (each sampled every 20 ms), which is what the systemd
service's cgroup holds on a controller (here also the emulators, printed with them).

    bench/daemon_explain_rss.py BUILD_DIR [--machine config/machine-example.toml] [--memory-mb MB] [--set KEY=VALUE]

--set passes a session option to `guideway start dbb` (docs/protocol.md). The emulated ballbar follows the
session's feed and radius (guidewayd tells it when the session starts, docs/configuration.md `[[emulator]]`):
`--set feed_mm_per_min=500` gives 2 x ~18k samples.
"""
import argparse
import json
import os
import shutil
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
            if key in ("VmRSS", "VmHWM", "RssAnon", "RssShmem"):
                out[key] = int(rest.split()[0])
    return out


def children(pid):
    """The daemon's child processes, whichever of its threads started them: (pid, cmdline) of each."""
    out, kids = [], []
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return out
    for t in tasks:
        try:
            with open(f"/proc/{pid}/task/{t}/children") as f:
                kids += [int(k) for k in f.read().split()]
        except OSError:
            pass
    for k in kids:
        try:
            with open(f"/proc/{k}/cmdline", "rb") as f:
                out.append((k, f.read().replace(b"\0", b" ").decode(errors="replace")))
        except OSError:
            pass
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("build")
    ap.add_argument("--machine", default=os.path.join(ROOT, "config", "machine-example.toml"))
    ap.add_argument("--memory-mb", type=int, help="[explain] memory_mb of the daemon's config (default: none)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a session option of `guideway start dbb` (repeatable)")
    ap.add_argument("--emulator-feed-mm-min", type=float,
                    help="the embedded default with its DBB emulator's program at this feed (for a daemon whose "
                         "emulator does not follow the session's feed: main before mem10)")
    ap.add_argument("--keep", action="store_true", help="keep the temporary directory (log, state, recordings)")
    ap.add_argument("--session-analysis", choices=["process", "daemon"],
                    help="[daemon] session_analysis (default: the daemon's own default)")
    o = ap.parse_args()
    d = tempfile.mkdtemp(prefix="daemon_explain_rss_")
    env = dict(os.environ, XDG_RUNTIME_DIR=os.path.join(d, "run"), XDG_STATE_HOME=os.path.join(d, "state"))
    os.makedirs(env["XDG_RUNTIME_DIR"], mode=0o700)
    daemon = [os.path.join(o.build, "daemon", "guidewayd"), "--emulator-machine", o.machine]
    if o.memory_mb is not None or o.emulator_feed_mm_min is not None or o.session_analysis is not None:
        # A copy of the embedded default (a configuration file replaces it whole) with what was asked.
        text = subprocess.run([daemon[0], "--print-default-config"], capture_output=True, text=True,
                              check=True).stdout
        if o.emulator_feed_mm_min is not None:
            feed = '"--feed-mm-min", "1000"'
            assert feed in text, "the default's DBB emulator no longer runs at 1000 mm/min"
            text = text.replace(feed, f'"--feed-mm-min", "{o.emulator_feed_mm_min:g}"')
        if o.session_analysis is not None:
            text = text.replace("[daemon]\n", f'[daemon]\nsession_analysis = "{o.session_analysis}"\n', 1)
        if o.memory_mb is not None:
            text += f"\n[explain]\nmemory_mb = {o.memory_mb}\n"
        cfg = os.path.join(d, "guidewayd.toml")
        with open(cfg, "w") as f:
            f.write(text)
        daemon += ["--config", cfg]
    cli = os.path.join(o.build, "cli", "guideway")
    log = open(os.path.join(d, "guidewayd.log"), "w")
    p = subprocess.Popen(daemon, env=env, stdout=log, stderr=subprocess.STDOUT)
    # The daemon's VmRSS; its analysis process's (`guidewayd --analyse-session`, session_analysis = "process")
    # VmHWM; the two together as sampled at the same moment (the service's cgroup less the emulators); and
    # that with the emulators (the cgroup of the emulated set-up).
    # The cgroup charges a page once: the child's program pages (the same file as the daemon's) are the daemon's
    # already, so "charged" adds only what the child holds of its own (RssAnon + RssShmem).
    peak = {"VmRSS": 0, "child_hwm": 0, "analysis_pids": set(), "daemon_and_child": 0, "with_emulators": 0,
            "charged": 0}
    stop = threading.Event()

    def sample():
        while not stop.is_set() and p.poll() is None:
            try:
                s = status_kb(p.pid)
            except OSError:
                return
            analysis = analysis_own = emulators = 0
            for k, cmd in children(p.pid):
                try:
                    c = status_kb(k)
                except OSError:
                    continue
                if "--analyse-session" in cmd:
                    peak["analysis_pids"].add(k)
                    peak["child_hwm"] = max(peak["child_hwm"], c.get("VmHWM", 0))
                    analysis += c.get("VmRSS", 0)
                    analysis_own += c.get("RssAnon", 0) + c.get("RssShmem", 0)
                else:
                    emulators += c.get("VmRSS", 0)
            peak["VmRSS"] = max(peak["VmRSS"], s.get("VmRSS", 0))
            peak["daemon_and_child"] = max(peak["daemon_and_child"], s.get("VmRSS", 0) + analysis)
            peak["with_emulators"] = max(peak["with_emulators"], s.get("VmRSS", 0) + analysis + emulators)
            peak["charged"] = max(peak["charged"], s.get("VmRSS", 0) + analysis_own)
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
              f"{o.memory_mb if o.memory_mb is not None else 'default'}; session options {' '.join(o.set) or 'default'}; "
              f"emulator feed {o.emulator_feed_mm_min or 'default'}; session_analysis {o.session_analysis or 'default'}")
        print(f"VmHWM before the session {before['VmHWM'] / 1024:.1f} MB (VmRSS {before['VmRSS'] / 1024:.1f})")
        print(f"VmHWM at the session's PARAMS {at_params['VmHWM'] / 1024:.1f} MB")
        print(f"VmHWM after its EXPLAIN {after['VmHWM'] / 1024:.1f} MB (VmRSS {after['VmRSS'] / 1024:.1f}); "
              f"VmRSS sampled at most {peak['VmRSS'] / 1024:.1f} MB")
        print(f"guidewayd CPU {(int(cpu[11]) + int(cpu[12])) / ticks:.1f} s (its reaped children's "
              f"{(int(cpu[13]) + int(cpu[14])) / ticks:.1f} s)")
        print(f"analysis processes {len(peak['analysis_pids'])}, their VmHWM sampled at most "
              f"{peak['child_hwm'] / 1024:.1f} MB; daemon + analysis VmRSS at most "
              f"{peak['daemon_and_child'] / 1024:.1f} MB (its program pages counted once: "
              f"{peak['charged'] / 1024:.1f} MB); with the emulators {peak['with_emulators'] / 1024:.1f} MB; "
              f"load {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
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
        log.close()
        if o.keep:
            print(f"kept {d} (the daemon's log, state and recordings)")
        else:
            shutil.rmtree(d, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
