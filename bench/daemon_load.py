#!/usr/bin/env python3
"""Daemon load and latency benchmark (bench/README.md, "Daemon load and latency").

Runs the real guidewayd with the four guideway-emulate instruments on their real transports at
rising sample rates, then with 100 watching clients of which one never reads. Standard library only.

Per rate step (a fresh daemon each, from a temporary TOML config):
  - per device: sustained rate (driver `samples` counter over the step) and losses (`overruns`,
    ring `drops`, `seq_gaps`, `bad_frames`, `timeouts`, `reconnects`, and the driver's own loss
    counters from `driver_counters`: lost_samples, dropped_frames, ...);
  - sample-to-publish latency: every SAMPLE message carries t_mono_ns (CLOCK_MONOTONIC when the
    sample was taken); this client reads CLOCK_MONOTONIC when the line arrives. sample_publish_hz
    is set to 100000, so the pipeline publishes the newest sample of every batch it pops;
  - guidewayd CPU (utime+stime of /proc/PID/stat over the step) per 1 k samples/s, the emulators'
    CPU for context, and guidewayd's VmRSS / VmHWM.
Then the client phase: 99 reading clients alone, then the same 99 plus one that subscribes and never
reads; their SAMPLE counts and latencies with and without it, and when the daemon drops it.

The micrometer runs in the driver's polled mode (one Modbus request per sample) or its buffered mode
(the emulated amplifier samples at the step's rate into its register ring; the driver reads the new
part every poll_period_ms); --micrometer polled,buffered runs every step in both, side by side.

Usage: bench/daemon_load.py BUILD_DIR [--rates 1000,2000,5000,10000] [--step-s 10] [--json OUT] [--syscalls]
       [--micrometer polled|buffered|polled,buffered] [--micrometer-poll-ms MS]
"""

import argparse
import json
import os
import re
import select
import selectors
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time

CLK_TCK = os.sysconf("SC_CLK_TCK")
T_RE = re.compile(rb'"t_mono_ns":(\d+)')
DEV_RE = re.compile(rb'"device":"([^"]+)"')

# Highest rate each driver/transport accepts (see bench/README.md for why).
CEILING_HZ = {
    "dbb": 10000.0,             # dbb-can: sync_rate_hz <= 10000
    "micrometer": 10000.0,      # micrometer-modbus: poll_hz <= 10000 (one Modbus TCP round trip per sample)
    "autocollimator": 1000.0,   # autocollimator-serial: stream_period_ms is an integer >= 1
    "profilometer": None,       # profilometer-tcp: the emulator's --points-per-s, no driver limit
}


def mono_ns():
    return time.clock_gettime_ns(time.CLOCK_MONOTONIC)


# Who produces the DBB's SYNC (--dbb-sync): "produce" = guidewayd at sync_rate_hz; "listen" = the
# emulator, like a CNC controller, and the driver reads in batches every DBB_READ_PERIOD_US (None:
# the driver's default).
DBB_SYNC = "listen"
DBB_READ_PERIOD_US = None


def dbb_toml(rate_hz):
    """The DBB emulator's arguments and the device's SYNC keys for DBB_SYNC."""
    if DBB_SYNC == "produce":
        return "", f'sync = "produce"\nsync_rate_hz = {rate_hz}'
    keys = 'sync = "listen"' + ("" if DBB_READ_PERIOD_US is None else f"\nread_period_us = {DBB_READ_PERIOD_US}")
    return f', "--sync", "produce", "--sync-rate-hz", "{rate_hz}"', keys


# The micrometer's driver mode for the next daemon (--micrometer); poll_ms None = the driver's default.
MICROMETER = {"mode": "polled", "poll_ms": None}


def micrometer_toml(rate_hz):
    """The micrometer's emulator and device tables in MICROMETER's mode."""
    if MICROMETER["mode"] == "polled":
        emulator_args, device_keys = "", f"poll_hz = {rate_hz}\n"
    else:
        emulator_args = f', "--ring-rate-hz", "{rate_hz}", "--ring-samples", "16384"'
        poll = "" if MICROMETER["poll_ms"] is None else f"poll_period_ms = {MICROMETER['poll_ms']}\n"
        device_keys = (f"{poll}  [device.buffer]\n  counter_address = 100\n  ring_address = 200\n"
                       f"  ring_samples = 16384\n  sample_rate_hz = {rate_hz}\n")
    return f"""
[[emulator]]
name = "gauge"
instrument = "micrometer"
args = ["--tcp", "127.0.0.1:0"{emulator_args}]

[[device]]
name = "micrometer"
driver = "micrometer-modbus"
transport = "tcp"
host = "emulator:gauge:host"
port = "emulator:gauge:port"
{device_keys}"""


def config_toml(rt, state, rates, publish_hz, client_queue_bytes, status_period_s=1.0, extra_toml="", devices=None,
                daemon_keys=""):
    """A guidewayd config with the four emulators at the given per-instrument rates (Hz), or only the
    instruments named in `devices`; daemon_keys (more [daemon] keys) and extra_toml (more tables:
    [mqtt], ...) at the end."""
    ac_period_ms = max(1, round(1000.0 / rates["autocollimator"]))
    dbb_args, dbb_sync = dbb_toml(rates["dbb"])
    blocks = {"dbb": f"""
[[emulator]]
name = "can"
instrument = "dbb"
args = ["--bus", "unix:{{runtime_dir}}/can-bus.sock", "--program", "lai", "--feed-mm-min", "5000", "--pause-s", "1"{dbb_args}]

[[device]]
name = "dbb"
driver = "dbb-can"
bus = "emulator:can"
{dbb_sync}
  [[device.encoder]]
  channel = "bar_length"
  node_id = 1
  resolution_nm = 100
  offset_mm = 100.0
  [[device.encoder]]
  channel = "x"
  node_id = 2
  resolution_nm = 100
  [[device.encoder]]
  channel = "y"
  node_id = 3
  resolution_nm = 100
""", "autocollimator": f"""
[[emulator]]
name = "ac"
instrument = "autocollimator"
args = ["--link", "{{runtime_dir}}/autocollimator.pty"]

[[device]]
name = "autocollimator"
driver = "autocollimator-serial"
port = "{{runtime_dir}}/autocollimator.pty"
mode = "stream"
stream_period_ms = {ac_period_ms}
""", "micrometer": micrometer_toml(rates["micrometer"]), "profilometer": f"""
[[emulator]]
name = "profiler"
instrument = "profilometer"
args = ["--port", "0", "--points-per-s", "{rates["profilometer"]}"]

[[device]]
name = "profilometer"
driver = "profilometer-tcp"
host = "emulator:profiler:host"
port = "emulator:profiler:port"
"""}
    return f"""
[daemon]
socket = "{rt}/guideway.sock"
state_dir = "{state}"
log_level = "warn"
status_period_s = {status_period_s}
sample_publish_hz = {publish_hz}
client_queue_bytes = {client_queue_bytes}
{daemon_keys}
""" + "".join(b for k, b in blocks.items() if devices is None or k in devices) + extra_toml


class Conn:
    """One JSON Lines connection to the daemon."""

    def __init__(self, path):
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.connect(path)
        self.buf = b""

    def send(self, obj):
        self.sock.sendall((json.dumps(obj) + "\n").encode())

    def lines(self, timeout):
        """Reads what is there (waiting up to timeout s); returns (receipt_ns, [lines])."""
        r, _, _ = select.select([self.sock], [], [], timeout)
        if not r:
            return mono_ns(), []
        data = self.sock.recv(1 << 20)
        now = mono_ns()
        if not data:
            raise ConnectionError("daemon closed the connection")
        self.buf += data
        *full, self.buf = self.buf.split(b"\n")
        return now, full

    def request(self, obj, cls, timeout=5.0, on_other=None):
        self.send(obj)
        end = time.monotonic() + timeout
        reply = None
        while reply is None and time.monotonic() < end:
            now, lines = self.lines(0.2)
            for line in lines:
                if reply is None and line.startswith(b'{"class":"' + cls.encode()):
                    reply = json.loads(line)
                elif on_other:
                    on_other(now, line)
        if reply is None:
            raise TimeoutError(f"no {cls} reply")
        return reply

    def close(self):
        self.sock.close()


def proc_cpu_s(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK  # utime, stime (fields 14, 15)


def task_stats(pid):
    """Per thread of pid: {tid: {"name", "cpu_s", "wakeups", "preempted"}}: utime+stime, and the
    voluntary context switches (each a sleep the thread was woken from) and involuntary ones from
    /proc/PID/task/TID/status."""
    out = {}
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{task}/comm") as f:
                name = f.read().strip()
            st = {"name": name, "cpu_s": proc_cpu_s(f"{pid}/task/{task}"), "wakeups": 0, "preempted": 0}
            with open(f"/proc/{pid}/task/{task}/status") as f:
                for line in f:
                    if line.startswith("voluntary_ctxt_switches:"):
                        st["wakeups"] = int(line.split()[1])
                    elif line.startswith("nonvoluntary_ctxt_switches:"):
                        st["preempted"] = int(line.split()[1])
            out[int(task)] = st
        except OSError:
            pass
    return out


def task_deltas(t0, t1, dt):
    """Per thread alive at both ends, in creation order: name, CPU % of a core, wake-ups/s, preemptions/s."""
    return [{"tid": tid, "name": t1[tid]["name"], "cpu_pct": round(100.0 * (t1[tid]["cpu_s"] - t0[tid]["cpu_s"]) / dt, 2),
             "wakeups_per_s": round((t1[tid]["wakeups"] - t0[tid]["wakeups"]) / dt, 1),
             "preempted_per_s": round((t1[tid]["preempted"] - t0[tid]["preempted"]) / dt, 1)}
            for tid in sorted(t1) if tid in t0]


def proc_mem_kib(pid):
    out = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(("VmRSS:", "VmHWM:")):
                out[line.split(":")[0]] = int(line.split()[1])
    return out


def children(pid):
    kids = []
    for task in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{task}/children") as f:
                kids += [int(x) for x in f.read().split()]
        except OSError:
            pass
    return kids


def loadavg():
    with open("/proc/loadavg") as f:
        return [float(x) for x in f.read().split()[:3]]


def pct(values, q):
    if not values:
        return float("nan")
    s = sorted(values)
    return s[min(len(s) - 1, int(q * len(s)))]


class Daemon:
    def __init__(self, build, rates, publish_hz, client_queue_bytes, status_period_s=1.0, extra_toml="", devices=None,
                 daemon_keys="", env=None):
        self.tmp = tempfile.mkdtemp(prefix="gw-load-")
        rt, state = f"{self.tmp}/rt", f"{self.tmp}/state"
        os.makedirs(rt)
        os.makedirs(state)
        self.socket = f"{rt}/guideway.sock"
        cfg = f"{self.tmp}/bench.toml"
        with open(cfg, "w") as f:
            f.write(config_toml(rt, state, rates, publish_hz, client_queue_bytes, status_period_s, extra_toml, devices,
                                daemon_keys))
        self.log = open(f"{self.tmp}/guidewayd.log", "w")
        self.proc = subprocess.Popen([f"{build}/daemon/guidewayd", "--config", cfg], stdout=self.log,
                                     stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                     env={**os.environ, **(env or {})})
        end = time.monotonic() + 30
        while not os.path.exists(self.socket):
            if self.proc.poll() is not None or time.monotonic() > end:
                self.log.flush()
                raise RuntimeError("guidewayd did not start:\n" + open(f"{self.tmp}/guidewayd.log").read())
            time.sleep(0.05)

    def status(self, conn, on_other=None):
        return conn.request({"class": "status"}, "STATUS", on_other=on_other)

    def wait_streaming(self, conn, timeout=20):
        """Waits until every device streams; after timeout goes on with those that do (and says so)."""
        end = time.monotonic() + timeout
        while True:
            st = self.status(conn)
            if all(d["state"] == "streaming" and d["counters"]["samples"] > 0 for d in st["devices"]):
                return st
            if time.monotonic() > end:
                print("  not streaming: " + json.dumps([(d["name"], d["state"], d.get("reason"))
                                                        for d in st["devices"] if d["state"] != "streaming"]),
                      file=sys.stderr)
                return st
            time.sleep(0.2)

    def stop(self):
        terminate(self.proc)
        self.log.close()
        shutil.rmtree(self.tmp, ignore_errors=True)


def terminate(proc, timeout=10):
    """SIGTERM, and SIGKILL when it has not exited after timeout s."""
    if proc.poll() is not None:
        return
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def device_deltas(st0, st1, dt):
    out = {}
    d0 = {d["name"]: d for d in st0["devices"]}
    for d in st1["devices"]:
        a = d0[d["name"]]
        c0, c1 = a["counters"], d["counters"]
        out[d["name"]] = {
            "rate_hz": (c1["samples"] - c0["samples"]) / dt,
            "overruns": c1["overruns"] - c0["overruns"],
            "ring_drops": d["ring"]["drops"] - a["ring"]["drops"],
            "seq_gaps": d.get("seq_gaps", 0) - a.get("seq_gaps", 0),
            "bad_frames": c1["bad_frames"] - c0["bad_frames"],
            "timeouts": c1["timeouts"] - c0["timeouts"],
            "reconnects": c1["reconnects"] - c0["reconnects"],
            "driver_losses": driver_losses(a, d),
            "state": d["state"],
        }
    return out


# The drivers' own counters that say samples were lost (docs/protocol.md, driver_counters, for each
# one's unit: samples, frames, cycles, polls, events, traverses, points). Left out: error_frames and
# exceptions (already in bad_frames), untimed_frames (published), profiles_completed (progress).
LOSS_COUNTERS = ("lost_samples", "ring_overruns", "counter_resets", "dropped_frames", "partial_cycles",
                 "profiles_partial", "points_lost")


def driver_losses(d0, d1):
    """Increase of each loss counter over the step (a daemon before protocol 1.1 sends none)."""
    c0, c1 = d0.get("driver_counters", {}), d1.get("driver_counters", {})
    return {k: c1[k] - c0.get(k, 0) for k in LOSS_COUNTERS if k in c1 and c1[k] != c0.get(k, 0)}


def emulator_name(pid):
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            args = f.read().split(b"\0")
        return args[1].decode() if len(args) > 1 else str(pid)
    except OSError:
        return str(pid)


def measure(build, rates, publish_hz, step_s, warmup_s, devices=None):
    """One daemon at `rates` (with the instruments named in `devices`, default all four): counters, CPU,
    memory and (when publishing) SAMPLE latency over step_s."""
    daemon = Daemon(build, rates, publish_hz=publish_hz, client_queue_bytes=4 << 20, devices=devices)
    try:
        conn = Conn(daemon.socket)
        daemon.wait_streaming(conn)
        conn.send({"class": "watch", "classes": ["SAMPLE"]})
        lat = {k: [] for k in rates if devices is None or k in devices}
        pipeline = {"latency_max_us": 0.0, "outbox_dropped": 0}
        recording = [False]

        def on_line(now, line):
            if recording[0] and line.startswith(b'{"class":"SAMPLE"'):
                t = T_RE.search(line)
                dev = DEV_RE.search(line)
                if t and dev:
                    lat[dev.group(1).decode()].append((now - int(t.group(1))) / 1000.0)

        def drain(seconds):
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                now, lines = conn.lines(0.05)
                for line in lines:
                    on_line(now, line)

        drain(warmup_s)
        pid = daemon.proc.pid
        st0 = daemon.status(conn, on_line)
        emus = children(pid)
        tids = sorted(int(t) for t in os.listdir(f"/proc/{pid}/task"))
        thread0 = {t: proc_cpu_s(f"{pid}/task/{t}") for t in tids}
        tasks0 = task_stats(pid)
        t0, cpu0, main0 = time.monotonic(), proc_cpu_s(pid), proc_cpu_s(f"{pid}/task/{pid}")
        ecpu0 = {p: proc_cpu_s(p) for p in emus}
        perf = start_perf(pid, step_s) if COUNT_SYSCALLS and publish_hz <= 10 else None
        recording[0] = True
        end = time.monotonic() + step_s
        while time.monotonic() < end:
            drain(min(1.0, end - time.monotonic()))
            st = daemon.status(conn, on_line)  # the pipeline figures are per status period
            p = st["pipeline"]
            pipeline["latency_max_us"] = max(pipeline["latency_max_us"], p["latency_max_us"])
            pipeline["outbox_dropped"] += p["outbox_dropped"]
        recording[0] = False
        st1 = daemon.status(conn, on_line)
        t1, cpu1, main1 = time.monotonic(), proc_cpu_s(pid), proc_cpu_s(f"{pid}/task/{pid}")
        dt = t1 - t0
        # Threads in creation order: main (event loop), then the daemon's helpers, one per device in
        # config order (dbb, autocollimator, micrometer, profilometer), the pipeline (bench/README.md).
        threads = [round(100.0 * (proc_cpu_s(f"{pid}/task/{t}") - thread0[t]) / dt, 1)
                   for t in tids if os.path.exists(f"/proc/{pid}/task/{t}")]
        tasks = task_deltas(tasks0, task_stats(pid), dt)
        ecpu = {emulator_name(p): 100.0 * (proc_cpu_s(p) - ecpu0[p]) / dt for p in emus if os.path.exists(f"/proc/{p}")}
        devs = device_deltas(st0, st1, dt)
        total_hz = sum(d["rate_hz"] for d in devs.values())
        all_lat = [x for v in lat.values() for x in v]
        cpu_pct = 100.0 * (cpu1 - cpu0) / dt
        conn.close()
        per_thread = finish_perf(perf, tids) if perf else None
        return {
            "syscalls_per_s_threads": per_thread and [round(v["syscalls"] / dt) for v in per_thread],
            "cswitches_per_s_threads": per_thread and [round(v["cswitches"] / dt) for v in per_thread],
            "publish_hz": publish_hz, "duration_s": dt, "devices": devs, "total_rate_hz": total_hz,
            "cpu_pct": cpu_pct, "cpu_pct_main_thread": 100.0 * (main1 - main0) / dt,
            "cpu_pct_threads": threads,
            "threads": tasks, "wakeups_per_s": round(sum(t["wakeups_per_s"] for t in tasks), 1),
            "cpu_pct_per_khz": cpu_pct / (total_hz / 1000.0) if total_hz else float("nan"),
            "emulators_cpu_pct": ecpu, "mem_kib": proc_mem_kib(pid),
            "published": len(all_lat),
            "latency_us": {"median": pct(all_lat, 0.5), "p99": pct(all_lat, 0.99), "max": max(all_lat, default=0.0)},
            "latency_us_by_device": {k: {"n": len(v), "median": pct(v, 0.5), "p99": pct(v, 0.99)}
                                     for k, v in lat.items()},
            "pipeline_latency_max_us": pipeline["latency_max_us"],
            "outbox_dropped": pipeline["outbox_dropped"],
            "loadavg_1min": loadavg()[0],
        }
    finally:
        daemon.stop()


COUNT_SYSCALLS = False  # --syscalls


def start_perf(pid, seconds):
    """perf stat over the measured window: system calls and context switches per guidewayd thread."""
    return subprocess.Popen(["perf", "stat", "-x,", "--per-thread", "-e", "raw_syscalls:sys_enter,context-switches",
                             "-p", str(pid), "--", "sleep", f"{seconds:.2f}"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def finish_perf(proc, tids):
    """Per thread in creation order (as cpu_pct_threads): {"syscalls": n, "cswitches": n}."""
    _, err = proc.communicate(timeout=60)
    counts = {t: {"syscalls": 0, "cswitches": 0} for t in tids}
    for line in err.splitlines():  # "guidewayd-1234,5678,,raw_syscalls:sys_enter,..."
        f = line.split(",")
        if len(f) < 4 or "-" not in f[0] or not f[1].isdigit():
            continue
        tid = int(f[0].rsplit("-", 1)[1])
        key = "syscalls" if f[3].startswith("raw_syscalls") else "cswitches" if f[3] == "context-switches" else None
        if tid in counts and key:
            counts[tid][key] = int(f[1])
    return [counts[t] for t in tids]


def step_rates(nominal_hz):
    return {k: (nominal_hz if c is None else min(nominal_hz, c)) for k, c in CEILING_HZ.items()}


def run_step(build, nominal_hz, step_s, warmup_s):
    """A rate step twice: publishing every pipeline batch (latency), and at the default 10 Hz (CPU)."""
    rates = step_rates(nominal_hz)
    return {"nominal_hz": nominal_hz, "rates_hz": rates, "dbb_sync": DBB_SYNC, "dbb_read_period_us": DBB_READ_PERIOD_US,
            "micrometer": dict(MICROMETER),
            "all": measure(build, rates, 100000, step_s, warmup_s),
            "default": measure(build, rates, 10, step_s, warmup_s)}


def reader_process(socket_path, n, seconds, bin_s):
    """--readers mode: n clients watching SAMPLE that read everything; per client SAMPLE lines per time bin."""
    sel = selectors.DefaultSelector()
    counts = []
    for i in range(n):
        c = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        c.connect(socket_path)
        c.sendall(b'{"class":"watch","classes":["SAMPLE"]}\n')
        c.setblocking(False)
        sel.register(c, selectors.EVENT_READ, i)
        counts.append({})
    print("ready", flush=True)
    closed = 0
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for key, _ in sel.select(0.05):
            try:
                data = key.fileobj.recv(1 << 20)
            except BlockingIOError:
                continue
            if not data:
                sel.unregister(key.fileobj)
                closed += 1
                continue
            b = mono_ns() // int(bin_s * 1e9)
            d = counts[key.data]
            d[b] = d.get(b, 0) + data.count(b"\n")  # ~all lines are SAMPLE; the two replies are noise
    print(json.dumps({"counts": [{str(k): v for k, v in d.items()} for d in counts], "closed": closed}), flush=True)


def run_clients(build, nominal_hz, publish_hz, phase_s, readers, queue_bytes):
    """`readers` clients that read (one of them, the probe, in this process for latency; the others in a
    reader process), first alone, then with one more client that subscribes and never reads."""
    rates = step_rates(nominal_hz)
    daemon = Daemon(build, rates, publish_hz=publish_hz, client_queue_bytes=queue_bytes)
    bin_s = 0.5
    try:
        ctl = Conn(daemon.socket)
        daemon.wait_streaming(ctl)
        rp = subprocess.Popen([sys.executable, __file__, "--readers", str(readers - 1), daemon.socket,
                               str(2 * phase_s + 6), str(bin_s)], stdout=subprocess.PIPE, text=True)
        if rp.stdout.readline().strip() != "ready":
            raise RuntimeError("reader process did not start")
        probe = Conn(daemon.socket)
        probe.send({"class": "watch", "classes": ["SAMPLE"]})
        pid = daemon.proc.pid

        def phase(seconds):
            lat = []
            main_cpu0 = proc_cpu_s(f"{pid}/task/{pid}")
            perf = start_perf(pid, seconds) if COUNT_SYSCALLS else None
            cpu0, t0, n0 = proc_cpu_s(pid), time.monotonic(), mono_ns()
            end = t0 + seconds
            while time.monotonic() < end:
                now, lines = probe.lines(0.05)
                for line in lines:
                    m = T_RE.search(line) if line.startswith(b'{"class":"SAMPLE"') else None
                    if m:
                        lat.append((now - int(m.group(1))) / 1000.0)
            dt = time.monotonic() - t0
            # The event loop (main thread) does the fan-out: its system calls show the send batching.
            main_syscalls = finish_perf(perf, [pid])[0]["syscalls"] / dt if perf else None
            return {"duration_s": dt, "cpu_pct": 100.0 * (proc_cpu_s(pid) - cpu0) / dt, "window_ns": (n0, mono_ns()),
                    "event_loop_cpu_pct": 100.0 * (proc_cpu_s(f"{pid}/task/{pid}") - main_cpu0) / dt,
                    "event_loop_syscalls_per_s": main_syscalls,
                    "probe_msgs_per_s": len(lat) / dt,
                    "latency_us": {"median": pct(lat, 0.5), "p99": pct(lat, 0.99), "max": max(lat, default=0.0)}}

        phase(2.0)  # settle
        s0 = daemon.status(ctl)["clients"]
        without = phase(phase_s)
        s1 = daemon.status(ctl)["clients"]
        silent = Conn(daemon.socket)
        silent.send({"class": "watch", "classes": ["SAMPLE"]})
        silent_t0, silent_wall = time.monotonic(), time.time()
        with_silent = phase(phase_s)
        s2 = daemon.status(ctl)["clients"]
        silent_t1 = time.monotonic()
        without["dropped_slow"] = s1["dropped_slow"] - s0["dropped_slow"]
        without["connected"] = s1["connected"]
        with_silent["dropped_slow"] = s2["dropped_slow"] - s1["dropped_slow"]
        with_silent["connected_at_end"] = s2["connected"]
        probe.close()  # before it stops reading, or the daemon drops it too
        # What the silent client finally sees: what was queued for it, then EOF when it was dropped.
        silent.sock.setblocking(False)
        got, eof = 0, False
        try:
            while True:
                d = silent.sock.recv(1 << 20)
                if not d:
                    eof = True
                    break
                got += len(d)
        except (BlockingIOError, ConnectionResetError):
            pass
        with_silent["silent_bytes_buffered"] = got
        with_silent["silent_eof"] = eof
        out, _ = rp.communicate(timeout=60)
        rdata = json.loads(out.strip().splitlines()[-1])

        def reader_rates(window):
            lo, hi = window[0] // int(bin_s * 1e9) + 1, window[1] // int(bin_s * 1e9) - 1  # whole bins only
            n_bins = max(1, hi - lo + 1)
            return [sum(v for k, v in d.items() if lo <= int(k) <= hi) / (n_bins * bin_s) for d in rdata["counts"]]

        for p in (without, with_silent):
            r = reader_rates(p.pop("window_ns"))
            p["reader_msgs_per_s"] = {"min": min(r), "median": statistics.median(r), "max": max(r)}
        log = open(f"{daemon.tmp}/guidewayd.log").read()
        drop_lines = [line for line in log.splitlines() if "queue overflow" in line]
        dropped_after_s = None
        for line in drop_lines:
            if "queue overflow" in line:  # "2026-11-21 10:19:56.214 warning client 101 dropped: ..."
                stamp = " ".join(line.split()[:2])
                wall = time.mktime(time.strptime(stamp[:19], "%Y-%m-%d %H:%M:%S")) + float("0" + stamp[19:])
                dropped_after_s = wall - silent_wall
                break
        with_silent["silent_dropped_after_s"] = dropped_after_s
        silent.close()
        ctl.close()
        return {"nominal_hz": nominal_hz, "publish_hz": publish_hz, "readers": readers,
                "client_queue_bytes": queue_bytes, "without_silent": without, "with_silent": with_silent,
                "readers_closed_by_daemon": rdata["closed"], "silent_phase_s": silent_t1 - silent_t0,
                "daemon_log_drop_lines": drop_lines[:3], "loadavg_1min": loadavg()[0]}
    finally:
        daemon.stop()


def fmt(x, digits=0):
    return "n/a" if x is None or x != x else f"{x:.{digits}f}"


def step_label(s):
    """A step's rate, with the DBB's SYNC mode when both modes ran and the micrometer's mode when buffered."""
    m = s.get("micrometer", {"mode": "polled"})
    return (f"{s['nominal_hz']:g}" + (f" {s['dbb_sync']}" if s.get("both_dbb_sync") else "")
            + ("" if m["mode"] == "polled" else " buffered"))


MIC_THREAD = 4  # creation order: main, helper, dbb, autocollimator, micrometer, profilometer, pipeline


def print_micrometer_modes(res):
    """Polled against buffered micrometer at the same step of the same run, with ratios."""
    pairs = {}
    for s in res["steps"]:
        pairs.setdefault(s["nominal_hz"], {})[s.get("micrometer", {"mode": "polled"})["mode"]] = s
    rows = [(hz, p["polled"], p["buffered"]) for hz, p in pairs.items() if "polled" in p and "buffered" in p]
    if not rows:
        return
    print("\nMicrometer polled vs buffered (same run; ratio = polled / buffered):\n")
    print("| step | mode | micrometer Hz delivered | micrometer thread CPU % | % per 1 k/s | system calls/s | "
          "context switches/s | guidewayd CPU % | micrometer latency median / p99 us | all devices p99 us |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")

    def figures(s):
        d, a = s["default"], s["all"]
        th = d["cpu_pct_threads"]
        sc, cs = d.get("syscalls_per_s_threads"), d.get("cswitches_per_s_threads")
        rate = d["devices"]["micrometer"]["rate_hz"]
        cpu = th[MIC_THREAD] if len(th) == 7 else float("nan")
        lat = a["latency_us_by_device"]["micrometer"]
        return {"rate": rate, "cpu": cpu, "per_k": cpu / (rate / 1000.0) if rate else float("nan"),
                "sc": sc[MIC_THREAD] if sc and len(sc) == 7 else None,
                "cs": cs[MIC_THREAD] if cs and len(cs) == 7 else None, "total": d["cpu_pct"],
                "med": lat["median"], "p99": lat["p99"], "all_p99": a["latency_us"]["p99"]}

    def ratio(x, y):
        return "n/a" if x is None or y is None or not y or x != x or y != y else f"{x / y:.1f}x"

    for hz, p, b in rows:
        fp, fb = figures(p), figures(b)
        for label, f in (("polled", fp), ("buffered", fb)):
            print(f"| {hz:g} | {label} | {f['rate']:.0f} | {f['cpu']:.1f} | {fmt(f['per_k'], 2)} | {fmt(f['sc'])} | "
                  f"{fmt(f['cs'])} | {f['total']:.1f} | {fmt(f['med'])} / {fmt(f['p99'])} | {fmt(f['all_p99'])} |")
        print(f"| {hz:g} | ratio | | {ratio(fp['cpu'], fb['cpu'])} | {ratio(fp['per_k'], fb['per_k'])} | "
              f"{ratio(fp['sc'], fb['sc'])} | {ratio(fp['cs'], fb['cs'])} | {ratio(fp['total'], fb['total'])} | "
              f"{ratio(fp['med'], fb['med'])} / {ratio(fp['p99'], fb['p99'])} | {ratio(fp['all_p99'], fb['all_p99'])} |")


def print_tables(res):
    m = res["machine"]
    print(f"Machine: {m['cpus']} CPUs, {m['model']}, kernel {m['kernel']}, {m['time']}")
    print(f"Load average (1, 5, 15 min): before {res['load_before']}, after {res['load_after']}\n")
    print("Per device (sample_publish_hz 10 run; losses summed over both runs of the step):\n")
    print("| step | device | set Hz | sustained Hz | overruns | ring drops | seq gaps | bad frames | timeouts | driver losses |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---|")
    for s in res["steps"]:
        for name, d in s["default"]["devices"].items():
            a = s["all"]["devices"][name]
            losses = {k: d.get("driver_losses", {}).get(k, 0) + a.get("driver_losses", {}).get(k, 0)
                      for k in LOSS_COUNTERS}
            losses_text = ", ".join(f"{k}={v}" for k, v in losses.items() if v) or "0"
            print(f"| {step_label(s)} | {name} | {s['rates_hz'][name]:g} | {d['rate_hz']:.0f} | "
                  + " | ".join(str(d[k] + a[k]) for k in ("overruns", "ring_drops", "seq_gaps", "bad_frames", "timeouts"))
                  + f" | {losses_text} |")
    for f in res.get("failed_steps", []):
        print(f"step {f['nominal_hz']:g} Hz failed: {f['error']}")
    print()
    print("| step | samples/s | guidewayd CPU % (publish 10 Hz) | CPU % per 1 k/s | CPU % publishing every batch |"
          " published SAMPLE/s | latency median us | p99 us | max us | pipeline max us | RSS MiB (peak) | emulators CPU % | load 1 min |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for s in res["steps"]:
        d, a = s["default"], s["all"]
        mem = d["mem_kib"]
        emus = ", ".join(f"{k[:4]} {v:.0f}" for k, v in d["emulators_cpu_pct"].items())
        print(f"| {step_label(s)} | {d['total_rate_hz']:.0f} | {d['cpu_pct']:.1f} | {d['cpu_pct_per_khz']:.2f} | "
              f"{a['cpu_pct']:.1f} | {a['published'] / a['duration_s']:.0f} | {fmt(a['latency_us']['median'])} | "
              f"{fmt(a['latency_us']['p99'])} | {fmt(a['latency_us']['max'])} | {fmt(a['pipeline_latency_max_us'])} | "
              f"{mem.get('VmRSS', 0) / 1024:.1f} ({mem.get('VmHWM', 0) / 1024:.1f}) | {emus} | {a['loadavg_1min']:.1f} |")
    print()
    print("| step | guidewayd wake-ups/s (voluntary context switches, /proc) | per thread by name: CPU % (wake-ups/s) |")
    print("|---|---:|---|")
    for s in res["steps"]:
        d = s["default"]
        if "threads" in d:
            print(f"| {step_label(s)} | {d['wakeups_per_s']:.0f} | "
                  + " / ".join(f"{t['name']} {t['cpu_pct']:.1f} ({t['wakeups_per_s']:.0f})" for t in d["threads"]) + " |")
    print()
    names = list(CEILING_HZ)
    print("| step | guidewayd CPU % per thread, creation order | " + " | ".join(f"{k} thread: % (% per 1 k/s)" for k in names)
          + " | pipeline thread % |")
    print("|---|---|" + "---:|" * (len(names) + 1))
    for s in res["steps"]:
        th = s["default"]["cpu_pct_threads"]
        row = f"| {step_label(s)} | {' / '.join(str(x) for x in th)} |"
        if len(th) == len(names) + 3:  # main, helper, the devices in config order, pipeline
            order = ["dbb", "autocollimator", "micrometer", "profilometer"]
            for k in names:
                pct_k = th[2 + order.index(k)]
                rate = s["default"]["devices"][k]["rate_hz"]
                row += f" {pct_k} ({pct_k / (rate / 1000.0):.2f}) |" if rate else " n/a |"
            row += f" {th[-1]} |"
        print(row)
    if any(s["default"].get("syscalls_per_s_threads") for s in res["steps"]):
        print()
        print("| step | samples/s | system calls per sample | per thread: system calls/s (context switches/s), creation order |")
        print("|---|---:|---:|---|")
        for s in res["steps"]:
            d = s["default"]
            sc, cs = d.get("syscalls_per_s_threads"), d.get("cswitches_per_s_threads")
            if not sc:
                continue
            per = sum(sc) / d["total_rate_hz"] if d["total_rate_hz"] else float("nan")
            print(f"| {step_label(s)} | {d['total_rate_hz']:.0f} | {per:.2f} | "
                  + " / ".join(f"{a} ({b})" for a, b in zip(sc, cs)) + " |")
    print()
    print("| step | " + " | ".join(f"{k} median / p99 us" for k in CEILING_HZ) + " |")
    print("|---|" + "---:|" * len(CEILING_HZ))
    for s in res["steps"]:
        by = s["all"]["latency_us_by_device"]
        print(f"| {step_label(s)} | " + " | ".join(f"{fmt(by[k]['median'])} / {fmt(by[k]['p99'])}"
                                                   for k in CEILING_HZ) + " |")
    modes = {}
    for s in res["steps"]:
        modes.setdefault(s["nominal_hz"], {})[s.get("dbb_sync", "produce")] = s
    pairs = [(hz, m["listen"], m["produce"]) for hz, m in modes.items() if "listen" in m and "produce" in m]
    if pairs:
        print("\nDBB: SYNC produced by the emulator (driver listens, batched reads) against produced by guidewayd, "
              "same run; ratio = listen / produce\n")
        print("| step | dbb Hz listen / produce | dbb thread % listen / produce (ratio) | % per 1 k/s listen / produce |"
              " context switches/s listen / produce (ratio) | system calls/s listen / produce |"
              " guidewayd CPU % listen / produce | dbb latency median us listen / produce | dbb p99 us listen / produce |"
              " all-device p99 us listen / produce |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for hz, ls, ps in pairs:
            def dbb(s):
                d = s["default"]
                th, sc, cs = d["cpu_pct_threads"], d.get("syscalls_per_s_threads"), d.get("cswitches_per_s_threads")
                rate = d["devices"]["dbb"]["rate_hz"]
                pct = th[2] if len(th) == len(CEILING_HZ) + 3 else float("nan")
                return {"rate": rate, "pct": pct, "per_k": pct / (rate / 1000.0) if rate else float("nan"),
                        "cs": cs[2] if cs else float("nan"), "sc": sc[2] if sc else float("nan"),
                        "cpu": d["cpu_pct"], "lat": s["all"]["latency_us_by_device"]["dbb"],
                        "p99_all": s["all"]["latency_us"]["p99"]}
            a, b = dbb(ls), dbb(ps)
            ratio = lambda x, y: fmt(x / y, 2) if y else "n/a"  # noqa: E731
            print(f"| {hz:g} | {a['rate']:.0f} / {b['rate']:.0f} | {fmt(a['pct'], 1)} / {fmt(b['pct'], 1)} "
                  f"({ratio(a['pct'], b['pct'])}) | {fmt(a['per_k'], 2)} / {fmt(b['per_k'], 2)} | "
                  f"{fmt(a['cs'])} / {fmt(b['cs'])} ({ratio(a['cs'], b['cs'])}) | {fmt(a['sc'])} / {fmt(b['sc'])} | "
                  f"{a['cpu']:.1f} / {b['cpu']:.1f} | {fmt(a['lat']['median'])} / {fmt(b['lat']['median'])} | "
                  f"{fmt(a['lat']['p99'])} / {fmt(b['lat']['p99'])} | {fmt(a['p99_all'])} / {fmt(b['p99_all'])} |")
    print_micrometer_modes(res)
    if res.get("clients"):
        c = res["clients"]
        print(f"\nClients: {c['readers']} reading clients at step {c['nominal_hz']:g} Hz, sample_publish_hz "
              f"{c['publish_hz']:g}, client_queue_bytes {c['client_queue_bytes']}\n")
        print("| phase | SAMPLE/s per reader (min / median / max) | probe latency median us | p99 us | max us |"
              " guidewayd CPU % | event loop CPU % | event loop system calls/s | clients dropped |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for label, p in ((f"{c['readers']} readers", c["without_silent"]),
                         (f"{c['readers']} readers + 1 silent", c["with_silent"])):
            r = p["reader_msgs_per_s"]
            print(f"| {label} | {r['min']:.0f} / {r['median']:.0f} / {r['max']:.0f} | {fmt(p['latency_us']['median'])} | "
                  f"{fmt(p['latency_us']['p99'])} | {fmt(p['latency_us']['max'])} | {p['cpu_pct']:.1f} | "
                  f"{fmt(p.get('event_loop_cpu_pct'), 1)} | {fmt(p.get('event_loop_syscalls_per_s'))} | "
                  f"{p['dropped_slow']} |")
        w = c["with_silent"]
        print(f"\nSilent client: dropped {fmt(w['silent_dropped_after_s'], 1)} s after it subscribed "
              f"(dropped_slow +{w['dropped_slow']}); reading afterwards it got {w['silent_bytes_buffered']} buffered "
              f"bytes, then EOF={w['silent_eof']}. Readers closed by the daemon: {c['readers_closed_by_daemon']}.")
        for line in c["daemon_log_drop_lines"]:
            print(f"    daemon log: {line}")


def machine():
    model = "?"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    return {"cpus": os.cpu_count(), "model": model, "kernel": os.uname().release,
            "time": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}


def main():
    if len(sys.argv) == 6 and sys.argv[1] == "--readers":  # the client phase's reader process
        reader_process(sys.argv[3], int(sys.argv[2]), float(sys.argv[4]), float(sys.argv[5]))
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("build", help="build tree holding daemon/guidewayd and the emulators (guideway_runtime)")
    ap.add_argument("--rates", default="1000,2000,5000,10000,20000,50000,100000",
                    help="nominal per-instrument rates in Hz; each instrument is capped at its ceiling")
    ap.add_argument("--step-s", type=float, default=8.0, help="measured seconds per step")
    ap.add_argument("--warmup-s", type=float, default=2.0, help="seconds after all devices stream, not measured")
    ap.add_argument("--clients-hz", type=float, default=10000.0, help="step rate of the client phase (0: skip it)")
    ap.add_argument("--clients-publish-hz", type=float, default=100.0, help="sample_publish_hz in the client phase")
    ap.add_argument("--clients-s", type=float, default=10.0, help="seconds per client phase")
    ap.add_argument("--clients-queue-bytes", type=int, default=65536, help="client_queue_bytes in the client phase")
    ap.add_argument("--readers", type=int, default=99, help="reading clients (the silent one makes 100)")
    ap.add_argument("--dbb-sync", choices=("listen", "produce", "both"), default="listen",
                    help="who produces the DBB's SYNC: the emulator (the driver listens, reading in batches), "
                         "guidewayd, or each step once per mode")
    ap.add_argument("--dbb-read-period-us", type=int, help="dbb-can read_period_us in listen mode (default: the driver's)")
    ap.add_argument("--micrometer", default="polled",
                    help="micrometer driver mode(s) per step: polled, buffered, or polled,buffered (both, side by side)")
    ap.add_argument("--micrometer-poll-ms", type=float, help="buffered mode's poll_period_ms (default: the driver's)")
    ap.add_argument("--json", help="write the raw results here")
    ap.add_argument("--syscalls", action="store_true",
                    help="also count system calls and context switches per guidewayd thread (perf stat; root or "
                         "perf_event_paranoid <= 1) in the publish-10-Hz run")
    args = ap.parse_args()
    global COUNT_SYSCALLS, DBB_SYNC, DBB_READ_PERIOD_US
    DBB_READ_PERIOD_US = args.dbb_read_period_us
    if args.syscalls and shutil.which("perf") is None:
        sys.exit("daemon_load: --syscalls needs perf (Debian package linux-perf; scripts/setup.sh installs it)")
    COUNT_SYSCALLS = args.syscalls
    if not os.access(f"{args.build}/daemon/guidewayd", os.X_OK):
        sys.exit(f"daemon_load: {args.build}/daemon/guidewayd not found (build the guideway_runtime target)")
    res = {"machine": machine(), "load_before": loadavg(), "steps": []}
    modes = args.micrometer.split(",")
    if any(m not in ("polled", "buffered") for m in modes):
        sys.exit("daemon_load: --micrometer takes polled, buffered or polled,buffered")
    MICROMETER["poll_ms"] = args.micrometer_poll_ms
    for r in (float(x) for x in args.rates.split(",")):
        for DBB_SYNC in (("listen", "produce") if args.dbb_sync == "both" else (args.dbb_sync,)):
            for mode in modes:
                MICROMETER["mode"] = mode
                print(f"step {r:g} Hz (dbb sync {DBB_SYNC}, micrometer {mode}) ...", file=sys.stderr, flush=True)
                try:
                    res["steps"].append(run_step(args.build, r, args.step_s, args.warmup_s))
                    res["steps"][-1]["both_dbb_sync"] = args.dbb_sync == "both"
                except (RuntimeError, OSError, TimeoutError) as e:  # report the step, go on with the next
                    print(f"  step {r:g} Hz failed: {e}", file=sys.stderr)
                    res.setdefault("failed_steps", []).append(
                        {"nominal_hz": r, "dbb_sync": DBB_SYNC, "micrometer": mode, "error": str(e)})
    DBB_SYNC = "listen" if args.dbb_sync == "both" else args.dbb_sync  # the client phase
    MICROMETER["mode"] = modes[0]
    if args.clients_hz > 0:
        print("clients ...", file=sys.stderr, flush=True)
        res["clients"] = run_clients(args.build, args.clients_hz, args.clients_publish_hz, args.clients_s,
                                     args.readers, args.clients_queue_bytes)
    res["load_after"] = loadavg()
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)
    print_tables(res)


if __name__ == "__main__":
    main()
