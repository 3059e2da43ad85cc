#!/usr/bin/env python3
"""Plant load benchmark (bench/README.md, "Plant: MQTT publishers into one broker and one fleet").

Phase 1, the plant: a real mosquitto on a free loopback port (tests/support/mqtt_broker.py), one
`guideway fleet serve` into a fresh SQLite database, and bench/plant_publishers: N publishers speaking
the daemon's exact publisher code (plant::Publisher), machines bench-00.., each M messages (a
session's PARAMS, EXPLAIN and report_ready EVENT after another, the golden results of the four kinds)
at --rate-hz each. Checked: every message is in the database (results and events tables, per machine
and class). Reported: the fleet's lag (received_utc - produced_utc of every stored message: publisher
queue, broker and fleet together, ms resolution), the fleet's and the broker's CPU
(/proc/PID/stat utime+stime from the first message handed over until the last one is stored), the
publishers' process CPU and what Publisher::publish() costs its caller.

Phase 2, the daemon: the real guidewayd with the four emulators (bench/daemon_load.py's config) at
--daemon-rate-hz per instrument, status_period_s = 0.2 (so the device table goes to the broker
5 times a second), --step-s measured seconds without [mqtt], then with [mqtt] to the same broker
(--rounds times, alternately). guidewayd's CPU in both, the ratio on/off, and the samples lost in
either (overruns, ring drops, sequence gaps, the drivers' own loss counters).

Usage: bench/plant_load.py BUILD_DIR [--publishers 50] [--messages 200] [--rate-hz 20] [--step-s 20]
       [--daemon-rate-hz 1000] [--rounds 1] [--json OUT]
"""

import argparse
import datetime
import json
import os
import shutil
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests", "support"))
import daemon_load as dl  # noqa: E402  (bench/: the daemon, its config, STATUS deltas, /proc CPU)
import mqtt_broker  # noqa: E402  (tests/support: mosquitto on a free port, mosquitto_sub)
from process_support import wait_for  # noqa: E402

PROBE = "plant-load-probe"  # the machine whose EVENT says the fleet is subscribed
DAEMON_MACHINE = "plant-load-daemon"


def utc_ms(text):
    """2026-11-26T11:20:15.123Z -> seconds since the epoch."""
    return datetime.datetime.strptime(text, "%Y-%m-%dT%H:%M:%S.%fZ").replace(tzinfo=datetime.timezone.utc).timestamp() \
        if "." in text else datetime.datetime.strptime(text, "%Y-%m-%dT%H:%M:%SZ").replace(
            tzinfo=datetime.timezone.utc).timestamp()


def query(db, sql, args=()):
    with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=10) as c:
        return c.execute(sql, args).fetchall()


def stored_count(db):
    if not os.path.exists(db):
        return 0
    try:
        return sum(query(db, f"SELECT COUNT(*) FROM {t} WHERE machine LIKE 'bench-%'")[0][0] for t in ("results", "events"))
    except sqlite3.OperationalError:  # the schema is not there yet
        return 0


class Fleet:
    """`guideway fleet serve` into `db`; started() once it stores what the broker sends."""

    def __init__(self, build, broker, db, prefix, log_path):
        self.log = open(log_path, "w")
        self.log_path = log_path
        self.proc = subprocess.Popen([f"{build}/cli/guideway", "fleet", "serve", "--broker", f"mqtt://127.0.0.1:{broker.port}",
                                      "--db", db, "--topic-prefix", prefix], stdout=self.log, stderr=subprocess.STDOUT,
                                     stdin=subprocess.DEVNULL)
        self.db, self.prefix, self.port = db, prefix, broker.port

    def wait_subscribed(self, timeout=30):
        """Sends a probe EVENT until the fleet has stored one (non-retained messages before that are lost)."""
        def stored():
            if self.proc.poll() is not None:
                raise RuntimeError("guideway fleet serve exited:\n" + open(self.log_path).read())
            subprocess.run(["mosquitto_pub", "-V", "mqttv5", "-h", "127.0.0.1", "-p", str(self.port), "-q", "1",
                            "-t", f"{self.prefix}/{PROBE}/event", "-m",
                            json.dumps({"class": "EVENT", "event": "probe", "time": time.time()})], check=True)
            try:
                return os.path.exists(self.db) and query(self.db, "SELECT COUNT(*) FROM events WHERE machine = ?", (PROBE,))[0][0]
            except sqlite3.OperationalError:
                return False
        if not wait_for(stored, timeout=timeout, poll_s=0.5):
            raise RuntimeError("guideway fleet serve stored nothing:\n" + open(self.log_path).read())

    def stop(self):
        dl.terminate(self.proc)
        self.log.close()


def expected_per_class(messages):
    """A publisher's message k is PARAMS (k % 3 == 0), EXPLAIN (1) or EVENT (2)."""
    return {"PARAMS": (messages + 2) // 3, "EXPLAIN": (messages + 1) // 3, "EVENT": messages // 3}


def check_stored(db, publishers, messages):
    """Per machine and class, what is missing (or extra) in the database: {} when everything is there."""
    want = expected_per_class(messages)
    got = {(m, c): n for m, c, n in query(db, "SELECT machine, class, COUNT(*) FROM results WHERE machine LIKE 'bench-%' "
                                              "GROUP BY machine, class")}
    got.update({(m, "EVENT"): n for m, n in query(db, "SELECT machine, COUNT(*) FROM events WHERE machine LIKE 'bench-%' "
                                                      "GROUP BY machine")})
    wrong = {}
    for i in range(publishers):
        m = f"bench-{i:02d}"
        for c, n in want.items():
            if got.get((m, c), 0) != n:
                wrong[f"{m} {c}"] = {"stored": got.get((m, c), 0), "sent": n}
    return wrong


def lag_ms(db):
    rows = query(db, "SELECT produced_utc, received_utc FROM results WHERE machine LIKE 'bench-%' "
                     "UNION ALL SELECT produced_utc, received_utc FROM events WHERE machine LIKE 'bench-%'")
    lags = [1000.0 * (utc_ms(r) - utc_ms(p)) for p, r in rows]
    return {"n": len(lags), "p50": dl.pct(lags, 0.5), "p99": dl.pct(lags, 0.99), "max": max(lags, default=float("nan"))}


def wait_stored(db, total, stall_s):
    """Until `total` messages are stored (True), or nothing more was stored for stall_s (False)."""
    last, last_change = -1, time.monotonic()
    while True:
        n = stored_count(db)
        if n >= total:
            return True
        if n != last:
            last, last_change = n, time.monotonic()
        elif time.monotonic() - last_change > stall_s:
            return False
        time.sleep(0.1)


def plant_phase(args, broker, fleet, tmp):
    run_id = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
    total = args.publishers * args.messages
    cpu0 = {"fleet": dl.proc_cpu_s(fleet.proc.pid), "broker": dl.proc_cpu_s(broker.proc.pid)}
    t0 = time.monotonic()
    pub = subprocess.run([f"{args.build}/bench/plant_publishers", "--broker", f"mqtt://127.0.0.1:{broker.port}",
                          "--publishers", str(args.publishers), "--messages", str(args.messages),
                          "--rate-hz", str(args.rate_hz), "--topic-prefix", args.topic_prefix, "--run-id", run_id],
                         capture_output=True, text=True)
    t_published = time.monotonic()
    if not pub.stdout.strip():
        raise RuntimeError("plant_publishers printed nothing:\n" + pub.stderr)
    publishers = json.loads(pub.stdout)
    all_stored = wait_stored(fleet.db, total, args.store_timeout_s)
    t1 = time.monotonic()
    cpu1 = {"fleet": dl.proc_cpu_s(fleet.proc.pid), "broker": dl.proc_cpu_s(broker.proc.pid)}
    dt = t1 - t0
    wrong = check_stored(fleet.db, args.publishers, args.messages)
    publishers.pop("per_publisher", None)
    return {
        "publishers": args.publishers, "messages_per_publisher": args.messages, "rate_hz_per_publisher": args.rate_hz,
        "messages": total, "stored": stored_count(fleet.db), "all_stored": bool(all_stored) and not wrong,
        "missing_or_extra": wrong, "duration_s": dt, "publishers_done_s": t_published - t0,
        "lag_ms": lag_ms(fleet.db),
        "cpu_pct": {k: 100.0 * (cpu1[k] - cpu0[k]) / dt for k in cpu0},
        "cpu_us_per_message": {k: 1e6 * (cpu1[k] - cpu0[k]) / total for k in cpu0},
        "fleet_mem_kib": dl.proc_mem_kib(fleet.proc.pid), "broker_mem_kib": dl.proc_mem_kib(broker.proc.pid),
        "database_bytes": sum(os.path.getsize(fleet.db + s) for s in ("", "-wal") if os.path.exists(fleet.db + s)),
        "plant_publishers": publishers, "plant_publishers_stderr": pub.stderr[-2000:],
        "loadavg_1min": dl.loadavg()[0],
    }


def mqtt_toml(port, prefix):
    return f'\n[mqtt]\nbroker = "mqtt://127.0.0.1:{port}"\nmachine = "{DAEMON_MACHINE}"\ntopic_prefix = "{prefix}"\n'


def thread_cpu_s(pid):
    """{tid: CPU s} of every thread of pid, from schedstat (ns; /proc/PID/stat counts 10 ms ticks)."""
    out = {}
    for t in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{t}/schedstat") as f:
                out[int(t)] = int(f.read().split()[0]) * 1e-9
        except OSError:
            pass
    return out


# guidewayd's threads in creation order: the event loop, a helper, with [mqtt] the publisher's, then one
# per device and the pipeline (daemon/daemon.cpp makes the publisher before it starts the devices).
PUBLISHER_THREAD = 2


def daemon_step(args, broker, mqtt_on, tmp):
    """One fresh guidewayd for --step-s, MQTT off or on: its CPU, the losses, what it published."""
    rates = dl.step_rates(args.daemon_rate_hz)
    extra = mqtt_toml(broker.port, args.topic_prefix) if mqtt_on else ""
    daemon = dl.Daemon(args.build, rates, publish_hz=10, client_queue_bytes=4 << 20, status_period_s=args.status_period_s,
                       extra_toml=extra)
    sub = None
    try:
        conn = dl.Conn(daemon.socket)
        daemon.wait_streaming(conn)
        if mqtt_on:
            sub = mqtt_broker.Subscriber(broker, f"{args.topic_prefix}/{DAEMON_MACHINE}/#",
                                         os.path.join(tmp, f"daemon-sub-{time.monotonic_ns()}.txt"))
        time.sleep(args.warmup_s)
        pid = daemon.proc.pid
        n_sub0 = len(sub.messages()) if sub else 0
        st0 = daemon.status(conn)
        th0 = thread_cpu_s(pid)
        t0, cpu0 = time.monotonic(), dl.proc_cpu_s(pid)
        time.sleep(args.step_s)
        t1, cpu1 = time.monotonic(), dl.proc_cpu_s(pid)
        th1 = thread_cpu_s(pid)
        st1 = daemon.status(conn)
        dt = t1 - t0
        devs = dl.device_deltas(st0, st1, dt)
        losses = {name: {k: d[k] for k in ("overruns", "ring_drops", "seq_gaps") if d[k]} | d["driver_losses"]
                  for name, d in devs.items()}
        received = (len(sub.messages()) - n_sub0) if sub else 0
        conn.close()
        threads = [round(100.0 * (th1[t] - th0[t]) / dt, 3) for t in sorted(th1) if t in th0]
        return {"mqtt": mqtt_on, "duration_s": dt, "cpu_pct": 100.0 * (cpu1 - cpu0) / dt,
                "cpu_pct_threads": threads, "event_loop_cpu_pct": threads[0],
                "publisher_thread_cpu_pct": threads[PUBLISHER_THREAD] if mqtt_on else None, "samples_per_s": sum(d["rate_hz"] for d in devs.values()),
                "devices": {k: round(d["rate_hz"]) for k, d in devs.items()},
                "losses": {k: v for k, v in losses.items() if v}, "mqtt_status": st1.get("mqtt"),
                "device_tables_received_per_s": received / dt if sub else None,
                "loadavg_1min": dl.loadavg()[0]}
    finally:
        if sub:
            sub.stop()
        daemon.stop()


def daemon_phase(args, broker, tmp):
    steps = []
    for r in range(args.rounds):
        for on in (False, True):
            steps.append(daemon_step(args, broker, on, tmp))
            print(f"  round {r + 1} MQTT {'on ' if on else 'off'}: guidewayd {steps[-1]['cpu_pct']:.1f} % CPU", file=sys.stderr)
    off = [s["cpu_pct"] for s in steps if not s["mqtt"]]
    on = [s["cpu_pct"] for s in steps if s["mqtt"]]
    loop_off = [s["event_loop_cpu_pct"] for s in steps if not s["mqtt"]]
    loop_on = [s["event_loop_cpu_pct"] for s in steps if s["mqtt"]]
    return {"daemon_rate_hz": args.daemon_rate_hz, "status_period_s": args.status_period_s, "step_s": args.step_s,
            "steps": steps, "cpu_pct_off": statistics.median(off), "cpu_pct_on": statistics.median(on),
            "event_loop_cpu_pct_off": statistics.median(loop_off), "event_loop_cpu_pct_on": statistics.median(loop_on),
            "publisher_thread_cpu_pct": statistics.median(s["publisher_thread_cpu_pct"] for s in steps if s["mqtt"]),
            # Each round's on/off pair ran back to back, so the median of the pairs' ratios is less at the mercy
            # of the machine's load than the ratio of the medians.
            "ratio_on_off": statistics.median(b / a for a, b in zip(off, on)),
            "ratios_per_round": [b / a for a, b in zip(off, on)],
            # What publishing itself adds (its thread, and the event loop's extra work) over the daemon without it:
            # the whole-process ratio above moves by more than that with the machine's load.
            "ratio_attributable": 1.0 + (statistics.median(s["publisher_thread_cpu_pct"] for s in steps if s["mqtt"])
                                         + statistics.median(loop_on) - statistics.median(loop_off)) / statistics.median(off)}


def fmt(x, digits=1):
    return "n/a" if x is None or x != x else f"{x:.{digits}f}"


def print_tables(res):
    m = res["machine"]
    print(f"Machine: {m['cpus']} CPUs, {m['model']}, kernel {m['kernel']}, {m['time']}")
    print(f"Load average (1, 5, 15 min): before {res['load_before']}, after {res['load_after']}\n")
    p = res.get("plant")
    if p:
        pp = p["plant_publishers"]
        print(f"Plant: {p['publishers']} publishers x {p['messages_per_publisher']} messages at "
              f"{p['rate_hz_per_publisher']:g} Hz each ({pp['payload_bytes'] / 1e6:.1f} MB of payload)\n")
        print("| messages | delivered (PUBACK) | dropped | stored in the fleet db | all stored | publishers done s | "
              "all stored s | lag p50 / p99 / max ms |")
        print("|---:|---:|---:|---:|---|---:|---:|---:|")
        lag = p["lag_ms"]
        print(f"| {p['messages']} | {pp['delivered']} | {pp['dropped']} | {p['stored']} | {'yes' if p['all_stored'] else 'NO'} | "
              f"{p['publishers_done_s']:.1f} | {p['duration_s']:.1f} | {fmt(lag['p50'], 0)} / {fmt(lag['p99'], 0)} / "
              f"{fmt(lag['max'], 0)} |")
        print()
        print("| process | CPU % over the run | CPU us per message | RSS MiB |")
        print("|---|---:|---:|---:|")
        print(f"| guideway fleet serve | {p['cpu_pct']['fleet']:.1f} | {p['cpu_us_per_message']['fleet']:.0f} | "
              f"{p['fleet_mem_kib'].get('VmRSS', 0) / 1024:.1f} |")
        print(f"| mosquitto | {p['cpu_pct']['broker']:.1f} | {p['cpu_us_per_message']['broker']:.0f} | "
              f"{p['broker_mem_kib'].get('VmRSS', 0) / 1024:.1f} |")
        print(f"| plant_publishers ({p['publishers']} publishers) | {pp['cpu_pct']:.1f} | {pp['cpu_us_per_message']:.0f} | |")
        c = pp["publish_call_ns"]
        print(f"\nPublisher::publish() on the caller's thread: p50 {c['p50'] / 1000:.1f} us, p99 {c['p99'] / 1000:.1f} us, "
              f"max {c['max'] / 1000:.1f} us (worst publisher's p99 {pp['publish_call_ns_worst_publisher_p99'] / 1000:.1f} us)")
        if p["missing_or_extra"]:
            print("missing or extra: " + json.dumps(p["missing_or_extra"])[:2000])
    d = res.get("daemon")
    if d:
        print(f"\nguidewayd, four emulators at {d['daemon_rate_hz']:g} Hz each, status_period_s {d['status_period_s']:g}, "
              f"{d['step_s']:g} s per step:\n")
        print("| MQTT | samples/s | guidewayd CPU % | event loop thread % | publisher thread % | losses | "
              "delivered (QoS 1) | device tables received/s | load 1 min |")
        print("|---|---:|---:|---:|---:|---|---:|---:|---:|")
        for s in d["steps"]:
            mq = s["mqtt_status"] or {}
            print(f"| {'on' if s['mqtt'] else 'off'} | {s['samples_per_s']:.0f} | {s['cpu_pct']:.1f} | "
                  f"{s['event_loop_cpu_pct']:.2f} | {fmt(s['publisher_thread_cpu_pct'], 2)} | "
                  f"{json.dumps(s['losses']) if s['losses'] else '0'} | {mq.get('delivered', '')} | "
                  f"{fmt(s['device_tables_received_per_s'])} | {s['loadavg_1min']:.1f} |")
        print(f"\nCPU ratio MQTT on / off: whole process {d['ratio_on_off']:.2f} (median of the rounds: "
              + ", ".join(f"{r:.2f}" for r in d["ratios_per_round"]) + f"); the publisher thread "
              f"{d['publisher_thread_cpu_pct']:.2f} % of a core, the event loop {d['event_loop_cpu_pct_off']:.2f} -> "
              f"{d['event_loop_cpu_pct_on']:.2f} %: attributable to publishing {d['ratio_attributable']:.3f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("build", help="build tree with bench/plant_publishers, cli/guideway, daemon/guidewayd, the emulators")
    ap.add_argument("--publishers", type=int, default=50)
    ap.add_argument("--messages", type=int, default=200, help="messages per publisher")
    ap.add_argument("--rate-hz", type=float, default=20.0, help="messages per second per publisher (0: as fast as it goes)")
    ap.add_argument("--topic-prefix", default="guideway")
    ap.add_argument("--store-timeout-s", type=float, default=15.0,
                    help="the fleet has stored what it will once nothing more was stored for this long")
    ap.add_argument("--step-s", type=float, default=20.0, help="measured seconds per guidewayd step (0: skip phase 2)")
    ap.add_argument("--warmup-s", type=float, default=2.0, help="seconds after all devices stream, not measured")
    ap.add_argument("--daemon-rate-hz", type=float, default=1000.0, help="per-instrument rate in phase 2")
    ap.add_argument("--status-period-s", type=float, default=0.2, help="guidewayd's status_period_s in phase 2 (both steps)")
    ap.add_argument("--rounds", type=int, default=3, help="MQTT off/on pairs in phase 2 (the ratio is their median)")
    ap.add_argument("--skip-plant", action="store_true", help="phase 2 only, without the fleet (the broker alone)")
    ap.add_argument("--broker-conf", action="append", default=[], metavar="LINE",
                    help="a mosquitto.conf line (repeatable), e.g. 'max_queued_messages 0'; default: Debian's defaults")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()
    why = mqtt_broker.missing()
    if why:
        sys.exit("plant_load: skipped: " + why)
    for tool in (["bench/plant_publishers", "cli/guideway"] if not args.skip_plant else []) + ["daemon/guidewayd"]:
        if not os.access(f"{args.build}/{tool}", os.X_OK):
            sys.exit(f"plant_load: {args.build}/{tool} not found (cmake --build BUILD --target plant_load_bench builds it all)")
    res = {"machine": dl.machine(), "load_before": dl.loadavg(), "broker_conf": args.broker_conf}
    tmp = tempfile.mkdtemp(prefix="gw-plant-load-")
    broker = fleet = None
    try:
        os.makedirs(f"{tmp}/broker")
        broker = mqtt_broker.Broker(f"{tmp}/broker", extra_conf=args.broker_conf)
        if not args.skip_plant:
            fleet = Fleet(args.build, broker, f"{tmp}/fleet.sqlite", args.topic_prefix, f"{tmp}/fleet.log")
            fleet.wait_subscribed()
            res["plant"] = plant_phase(args, broker, fleet, tmp)
        if args.step_s > 0:
            res["daemon"] = daemon_phase(args, broker, tmp)
    finally:
        if fleet:
            fleet.stop()
        if broker:
            broker.stop()
    res["load_after"] = dl.loadavg()
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)
    print_tables(res)
    shutil.rmtree(tmp, ignore_errors=True)
    ok = res.get("plant", {}).get("all_stored", True) and all(not s["losses"] for s in res.get("daemon", {}).get("steps", []))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
