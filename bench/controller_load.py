#!/usr/bin/env python3
"""Light on the controller PC (bench/README.md, "On the controller PC"): guidewayd at the four
instruments' full rates against the platform floor, before and after, in one run; then cyclictest on
one CPU with and without the daemon on the other. Standard library only (plus perf and cyclictest).

  python3 bench/controller_load.py AFTER_BUILD BEFORE_BUILD [--rounds 2] [--step-s 6] [--cyclictest-s 15]
      [--cyclictest-rounds 2] [--skip floor,daemons,alone,cyclictest] [--wake-periods micrometer=5,profilometer=2]
      [--json out.json]

AFTER_BUILD and BEFORE_BUILD each hold daemon/guidewayd and the emulators (guideway_runtime); the floor
comes from AFTER_BUILD/bench/platform_floor_bench. In order:
  1. the floor: platform_floor_bench's DbbReaderFloor (one thread waking every 900 us, taking the DBB's
     40 k frames/s off the socket and doing nothing else), CPU % of a core and wake-ups/s; beside it each
     other instrument's floor, its bare read on its own transport with the driver's decoding at the read
     period guidewayd uses (AutocollimatorReaderFloor, MicrometerReaderFloor, ProfilometerReaderFloor),
     the sum of the four, and all four read by one thread waking at the DBB's period (AllFourReaderFloor);
     the daemon's CPU is given as a ratio to the DBB floor, to the sum and to the all-four floor, its
     wake-ups against a budget: the DBB floor's plus one per period of each device that needs wake-ups
     of its own (--wake-periods, ms: by default the micrometer's poll_period_ms, 5, and the profilometer
     emulator's segment period, 2, each read as it comes; the autocollimator's lines, 1 ms apart, are
     read at the DBB's passes);
  2. `rounds` rounds of the two daemons, alternately first, each as bench/daemon_load.py measures a step
     (--rates 10000 --dbb-sync listen --micrometer buffered): CPU at sample_publish_hz 10, wake-ups/s
     (voluntary context switches of every thread, /proc), p99 sample-to-publish latency publishing
     every batch, losses;
  3. each instrument alone at its full rate in a daemon of each build: CPU per 1 k samples/s;
  3b. with --side-by-side N: both daemons at once, under the same load, gw-io's and the process's CPU
     over N windows of --step-s (on a machine others load, the one comparison of the builds that holds);
     then both at once publishing every batch, one client reading both for N x --step-s: each device's
     median and p99 sample-to-publish latency, before and after;
  4. cyclictest (SCHED_FIFO 95, 200 us interval) pinned to the last CPU: alone, beside the "after"
     daemon kept off that CPU (the kernel's isolated list stood in for by $GUIDEWAY_CPU_ISOLATED_FILE),
     beside it spread over every CPU, and beside the "before" daemon, `--cyclictest-rounds` times in
     turn; p99 and max latency, and the daemon's threads switched in on the measured CPU (perf,
     sched:sched_switch). The emulators are the daemon's children: they run where it may.
"""

import argparse
import json
import os
import selectors
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import daemon_load as dl  # noqa: E402

DEVICES = ("dbb", "autocollimator", "micrometer", "profilometer")


# platform_floor_bench's floors: the DBB's (the platform floor of issue 45), each other instrument's,
# and all four read by one thread at the DBB's period ("all_four").
FLOORS = {"dbb": "DbbReaderFloor/period_us:900/timestamps:1", "autocollimator": "AutocollimatorReaderFloor",
          "micrometer": "MicrometerReaderFloor", "profilometer": "ProfilometerReaderFloor",
          "all_four": "AllFourReaderFloor"}


def floors(build, repetitions):
    """Every floor of FLOORS, `repetitions` runs each: {device: [{"core_pct", "wakes_per_s"}, ...]}."""
    exe = f"{build}/bench/platform_floor_bench"
    out = subprocess.run([exe, "--benchmark_filter=^(" + "|".join(FLOORS.values()) + ")/",
                          f"--benchmark_repetitions={repetitions}", "--benchmark_format=json"],
                         capture_output=True, text=True, check=True).stdout
    runs = [b for b in json.loads(out)["benchmarks"] if b.get("run_type") == "iteration"]
    res = {}
    for name, prefix in FLOORS.items():
        res[name] = [{"core_pct": round(b["core_pct"], 2), "wakes_per_s": round(b.get("wakes_per_s", float("nan")))}
                     for b in runs if b["name"].startswith(prefix + "/")]
    return res


def median(xs):
    xs = sorted(x for x in xs if x == x)
    return xs[len(xs) // 2] if xs else None


def floor_figures(res):
    """Medians over both floor phases: DBB floor %, each instrument's floor %, their sum, the DBB floor's
    wake-ups/s and the wake-up budget (that plus 1000 / period_ms per entry of the wake periods); the
    all-four floor."""
    runs = {}
    for key in ("floors", "floors_after"):
        for name, rs in res.get(key, {}).items():
            runs.setdefault(name, []).extend(rs)
    if not runs and (res.get("floor_pct") or res.get("floor_pct_after")):  # a --json of before the instrument floors
        runs["dbb"] = [{"core_pct": x, "wakes_per_s": float("nan")} for x in res.get("floor_pct", []) +
                       res.get("floor_pct_after", [])]
    pct = {name: median([r["core_pct"] for r in rs]) for name, rs in runs.items()}
    wakes = {name: median([r["wakes_per_s"] for r in rs]) for name, rs in runs.items()}
    each = [pct.get(name) for name in DEVICES]
    total = sum(each) if None not in each else None
    periods = res.get("wake_periods_ms", {})
    budget = wakes.get("dbb") + sum(1000.0 / ms for ms in periods.values()) if wakes.get("dbb") else None
    return {"pct": pct, "wakes": wakes, "sum_pct": total, "all_four_pct": pct.get("all_four"), "budget": budget,
            "periods_ms": periods}


def daemon_round(build):
    rates = dl.step_rates(10000)
    cpu = dl.measure(build, rates, 10, ARGS.step_s, ARGS.warmup_s)
    lat = dl.measure(build, rates, 100000, ARGS.step_s, ARGS.warmup_s)
    losses = {}
    for run in (cpu, lat):
        for name, d in run["devices"].items():
            n = d["overruns"] + d["ring_drops"] + d["seq_gaps"] + sum(d["driver_losses"].values())
            losses[name] = losses.get(name, 0) + n
    return {"cpu_pct": cpu["cpu_pct"], "samples_per_s": cpu["total_rate_hz"], "wakeups_per_s": cpu["wakeups_per_s"],
            "threads": cpu["threads"], "p99_us": lat["latency_us"]["p99"], "median_us": lat["latency_us"]["median"],
            "p99_us_by_device": {k: v["p99"] for k, v in lat["latency_us_by_device"].items()},
            "rates_hz": {k: round(v["rate_hz"]) for k, v in cpu["devices"].items()}, "losses": losses,
            "loadavg_1min": cpu["loadavg_1min"]}


def alone(build, name):
    rates = dl.step_rates(10000)
    r = dl.measure(build, rates, 10, ARGS.step_s, ARGS.warmup_s, devices=[name])
    rate = r["devices"][name]["rate_hz"]
    return {"cpu_pct": r["cpu_pct"], "rate_hz": rate, "wakeups_per_s": r["wakeups_per_s"],
            "cpu_pct_per_khz": r["cpu_pct"] / (rate / 1000.0) if rate else float("nan")}


def start_both(builds, publish_hz, ds, conns):
    """Both daemons at full rate, into ds and conns (build: daemon, connection) once each streams."""
    for b, path in builds.items():
        ds[b] = dl.Daemon(path, dl.step_rates(10000), publish_hz=publish_hz, client_queue_bytes=4 << 20)
    for b, d in ds.items():
        conns[b] = dl.Conn(d.socket)
        d.wait_streaming(conns[b])


def side_by_side(builds, windows):
    """Both daemons at full rate at once: per window, each one's gw-io and process CPU % and samples/s."""
    ds, conns, tids = {}, {}, {}
    try:
        start_both(builds, 10, ds, conns)
        for b, d in ds.items():
            task = f"/proc/{d.proc.pid}/task"
            tids[b] = next(t for t in os.listdir(task) if open(f"{task}/{t}/comm").read().strip() == "gw-io")
        time.sleep(ARGS.warmup_s)
        out = []
        for _ in range(windows):
            st0 = {b: ds[b].status(conns[b]) for b in ds}
            cpu0 = {b: (dl.proc_cpu_s(f"{ds[b].proc.pid}/task/{tids[b]}"), dl.proc_cpu_s(ds[b].proc.pid)) for b in ds}
            t0 = time.monotonic()
            time.sleep(ARGS.step_s)
            dt = time.monotonic() - t0
            row = {"loadavg_1min": dl.loadavg()[0]}
            for b in ds:
                io, proc = dl.proc_cpu_s(f"{ds[b].proc.pid}/task/{tids[b]}"), dl.proc_cpu_s(ds[b].proc.pid)
                rate = sum(v["rate_hz"] for v in dl.device_deltas(st0[b], ds[b].status(conns[b]), dt).values())
                row[b] = {"gw_io_pct": 100 * (io - cpu0[b][0]) / dt, "cpu_pct": 100 * (proc - cpu0[b][1]) / dt,
                          "samples_per_s": rate}
            out.append(row)
        return out
    finally:
        for d in ds.values():
            d.stop()


def side_by_side_latency(builds, seconds):
    """Both daemons at full rate at once, each publishing the newest sample of every batch, one client
    reading both: per build and device, the median and p99 sample-to-publish latency (us) over the same
    `seconds` under the same load (the before/after comparison of latency that holds on a loaded machine)."""
    ds, conns, lat = {}, {}, {b: {k: [] for k in DEVICES} for b in builds}
    try:
        start_both(builds, 100000, ds, conns)
        sel = selectors.DefaultSelector()
        for b, c in conns.items():
            c.send({"class": "watch", "classes": ["SAMPLE"]})
            sel.register(c.sock, selectors.EVENT_READ, b)
        start = time.monotonic() + ARGS.warmup_s
        end = start + seconds
        while time.monotonic() < end:
            for key, _ in sel.select(0.05):
                c = conns[key.data]
                data = c.sock.recv(1 << 20)
                now = dl.mono_ns()
                if not data:
                    raise ConnectionError(f"{key.data} daemon closed the connection")
                c.buf += data
                *full, c.buf = c.buf.split(b"\n")
                if time.monotonic() < start:
                    continue
                for line in full:
                    t, dev = dl.T_RE.search(line), dl.DEV_RE.search(line)
                    if line.startswith(b'{"class":"SAMPLE"') and t and dev:
                        lat[key.data][dev.group(1).decode()].append((now - int(t.group(1))) / 1000.0)
        return {"seconds": seconds, "loadavg_1min": dl.loadavg()[0],
                **{b: {k: {"n": len(v), "median": dl.pct(v, 0.5), "p99": dl.pct(v, 0.99)} for k, v in by.items()}
                   for b, by in lat.items()}}
    finally:
        for d in ds.values():
            d.stop()


def histogram_stats(path):
    """p99 and max (us) from cyclictest's --histfile (one thread)."""
    counts, overflow, mx = [], 0, None
    with open(path) as f:
        for line in f:
            if line.startswith("# Max Latencies:"):
                mx = int(line.split(":")[1].split()[0])
            elif line.startswith("# Histogram Overflows:"):
                overflow = int(line.split(":")[1].split()[0])
            elif line[:1].isdigit():
                us, n = line.split()[:2]
                counts.append((int(us), int(n)))
    total = sum(n for _, n in counts) + overflow
    seen, p99 = 0, None
    for us, n in counts:
        seen += n
        if p99 is None and seen >= 0.99 * total:
            p99 = us
    return {"samples": total, "p99_us": p99 if p99 is not None else float("inf"), "max_us": mx,
            "overflows": overflow}


def switched_in(perf_data, tids):
    """sched_switch events on the recorded CPU whose next task is one of `tids`."""
    out = subprocess.run(["perf", "script", "-i", perf_data, "-F", "trace"], capture_output=True, text=True).stdout
    n = 0
    for line in out.splitlines():
        if "next_pid=" in line:
            pid = int(line.split("next_pid=")[1].split()[0])
            n += pid in tids
    return n


def cyclictest_phase(cpu, seconds, daemon=None):
    """cyclictest on `cpu` for `seconds` (beside `daemon`, a daemon_load.Daemon, if given)."""
    tmp = tempfile.mkdtemp(prefix="gw-ct-")
    hist = f"{tmp}/hist"
    perf_data = f"{tmp}/perf.data"
    perf = None
    if daemon is not None and shutil.which("perf"):
        perf = subprocess.Popen(["perf", "record", "-q", "-e", "sched:sched_switch", "-C", str(cpu), "-o", perf_data,
                                 "--", "sleep", str(seconds)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    ct = subprocess.run(["cyclictest", "-m", "-q", "-t1", "-a", str(cpu), "-p", "95", "-i", "200", "-D", f"{seconds}s",
                         "-h", "20000", f"--histfile={hist}"], capture_output=True, text=True)
    if ct.returncode != 0:
        raise RuntimeError("cyclictest: " + ct.stderr.strip())
    r = histogram_stats(hist)
    if daemon is not None:
        pid = daemon.proc.pid
        tids = {int(t) for t in os.listdir(f"/proc/{pid}/task")}
        emus = {int(t) for p in dl.children(pid) for t in os.listdir(f"/proc/{p}/task")}
        if perf is not None:
            perf.wait()
            r["daemon_switches_in_per_s"] = switched_in(perf_data, tids) / seconds
            r["emulator_switches_in_per_s"] = switched_in(perf_data, emus) / seconds
        r["daemon_cpus_allowed"] = open(f"/proc/{pid}/status").read().split("Cpus_allowed_list:")[1].split()[0]
    shutil.rmtree(tmp, ignore_errors=True)
    return r


def cyclictest_with(build, cpu, seconds, daemon_keys="", env=None):
    d = dl.Daemon(build, dl.step_rates(10000), publish_hz=10, client_queue_bytes=4 << 20, daemon_keys=daemon_keys,
                  env=env)
    try:
        conn = dl.Conn(d.socket)
        d.wait_streaming(conn)
        time.sleep(ARGS.warmup_s)
        st0, t0 = d.status(conn), time.monotonic()
        r = cyclictest_phase(cpu, seconds, d)
        st1 = d.status(conn)
        r["samples_per_s"] = round(sum(v["rate_hz"] for v in dl.device_deltas(st0, st1, time.monotonic() - t0).values()))
        conn.close()
        return r
    finally:
        d.stop()


def fmt(x, digits=0):
    return "n/a" if x is None or x != x else f"{x:.{digits}f}"


def main():
    global ARGS
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("after", help="build tree of the code under test")
    ap.add_argument("before", help="build tree to compare with (e.g. main)")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--step-s", type=float, default=6.0)
    ap.add_argument("--warmup-s", type=float, default=2.0)
    ap.add_argument("--floor-repetitions", type=int, default=3)
    ap.add_argument("--cyclictest-s", type=float, default=15.0)
    ap.add_argument("--cyclictest-rounds", type=int, default=2, help="each phase this many times, in turn")
    ap.add_argument("--side-by-side", type=int, default=0, metavar="N",
                    help="also run both daemons at once for N windows of --step-s (0: not)")
    ap.add_argument("--skip", default="", help="phases to leave out: floor,daemons,alone,cyclictest")
    ap.add_argument("--wake-periods", default="micrometer=5,profilometer=2",
                    help="devices with wake-ups of their own for the wake-up budget, name=period_ms,... "
                         "(default: the micrometer's poll_period_ms and the profilometer emulator's segment period; '' for none)")
    ap.add_argument("--json", help="write the raw results here")
    ARGS = ap.parse_args()
    dl.DBB_SYNC = "listen"
    dl.MICROMETER["mode"] = "buffered"
    skip = set(ARGS.skip.split(",")) - {""}
    builds = {"before": ARGS.before, "after": ARGS.after}
    res = {"machine": dl.machine(), "load_before": dl.loadavg(), "builds": builds,
           "wake_periods_ms": {k: float(v) for k, v in (p.split("=") for p in ARGS.wake_periods.split(",") if p)}}
    if "floor" not in skip:
        print("floors ...", file=sys.stderr, flush=True)
        res["floors"] = floors(ARGS.after, ARGS.floor_repetitions)
        res["floor_pct"] = [r["core_pct"] for r in res["floors"]["dbb"]]
    if "daemons" not in skip:
        res["rounds"] = []
        for r in range(ARGS.rounds):
            order = ("before", "after") if r % 2 == 0 else ("after", "before")
            row = {}
            for b in order:
                print(f"round {r + 1}: {b} ...", file=sys.stderr, flush=True)
                row[b] = daemon_round(builds[b])
            res["rounds"].append(row)
        if "floor" not in skip:  # the floors again after the daemons: the machine may have changed meanwhile
            res["floors_after"] = floors(ARGS.after, ARGS.floor_repetitions)
            res["floor_pct_after"] = [r["core_pct"] for r in res["floors_after"]["dbb"]]
    if "alone" not in skip:
        res["alone"] = {}
        for name in DEVICES:
            for b in ("before", "after"):
                print(f"{name} alone: {b} ...", file=sys.stderr, flush=True)
                res["alone"].setdefault(name, {})[b] = alone(builds[b], name)
    if ARGS.side_by_side > 0:
        print(f"side by side, {ARGS.side_by_side} windows ...", file=sys.stderr, flush=True)
        res["side_by_side"] = side_by_side(builds, ARGS.side_by_side)
        print("side by side, latency ...", file=sys.stderr, flush=True)
        res["side_by_side_latency"] = side_by_side_latency(builds, ARGS.side_by_side * ARGS.step_s)
    if "cyclictest" not in skip:
        cpu = sorted(os.sched_getaffinity(0))[-1]
        s = ARGS.cyclictest_s
        res["cyclictest_cpu"] = cpu
        iso = tempfile.NamedTemporaryFile("w", suffix=".isolated", delete=False)
        iso.write(f"{cpu}\n")
        iso.close()
        everywhere = ",".join(str(c) for c in sorted(os.sched_getaffinity(0)))
        phases = [("idle", lambda: cyclictest_phase(cpu, s)),
                  ("after, kept off the CPU", lambda: cyclictest_with(ARGS.after, cpu, s,
                                                                      env={"GUIDEWAY_CPU_ISOLATED_FILE": iso.name})),
                  ("after, on every CPU", lambda: cyclictest_with(ARGS.after, cpu, s,
                                                                  daemon_keys=f'cpu_affinity = "{everywhere}"')),
                  ("before (as shipped)", lambda: cyclictest_with(ARGS.before, cpu, s))]
        res["cyclictest"] = []
        for r in range(ARGS.cyclictest_rounds):
            for label, run in phases:
                print(f"cyclictest round {r + 1}: {label} ...", file=sys.stderr, flush=True)
                res["cyclictest"].append({"round": r + 1, "phase": label, **run()})
        os.unlink(iso.name)
    res["load_after"] = dl.loadavg()
    if ARGS.json:
        with open(ARGS.json, "w") as f:
            json.dump(res, f, indent=1)
    report(res)


def report(res):
    m = res["machine"]
    print(f"Machine: {m['cpus']} CPUs, {m['model']}, kernel {m['kernel']}, {m['time']}; "
          f"load average before {res['load_before']}, after {res['load_after']}\n")
    floors = res.get("floor_pct", []) + res.get("floor_pct_after", [])
    fl = sorted(floors)[len(floors) // 2] if floors else None
    ff = floor_figures(res)
    if floors:
        print(f"Floor (DbbReaderFloor, 900 us, timestamps): {', '.join(fmt(x, 2) for x in floors)} % of a core; "
              f"median {fmt(fl, 2)} %\n")
    if ff["pct"]:
        print("| floor (median of every run, both phases) | runs: CPU % of a core | median CPU % | wake-ups/s |")
        print("|---|---|---:|---:|")
        for name in FLOORS:
            rs = res.get("floors", {}).get(name, []) + res.get("floors_after", {}).get(name, [])
            print(f"| {name} ({FLOORS[name].split('/')[0]}) | {', '.join(fmt(r['core_pct'], 2) for r in rs)} | "
                  f"{fmt(ff['pct'].get(name), 2)} | {fmt(ff['wakes'].get(name))} |")
            if name == DEVICES[-1]:
                print(f"| sum of the four | | {fmt(ff['sum_pct'], 2)} | |")
        periods = ", ".join(f"{k} every {v:g} ms" for k, v in ff["periods_ms"].items()) or "none"
        print(f"\nWake-up budget: the DBB floor's {fmt(ff['wakes'].get('dbb'))}/s plus one per extra device period "
              f"({periods}) = {fmt(ff['budget'])}/s\n")
    if res.get("rounds"):
        print("| round | build | samples/s | CPU % | x floor | wake-ups/s | p99 us (all) | p99 us dbb / ac / mic / prof |"
              " losses | load | x sum of floors | x all-four floor | wake-ups / budget |")
        print("|---|---|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|")
        for i, row in enumerate(res["rounds"]):
            for b, r in row.items():
                by = r["p99_us_by_device"]
                print(f"| {i + 1} | {b} | {r['samples_per_s']:.0f} | {r['cpu_pct']:.1f} | "
                      f"{fmt(r['cpu_pct'] / fl if fl else None, 2)} | {r['wakeups_per_s']:.0f} | {fmt(r['p99_us'])} | "
                      + " / ".join(fmt(by.get(k)) for k in DEVICES) + f" | {sum(r['losses'].values())} | "
                      f"{r['loadavg_1min']:.1f} | {fmt(r['cpu_pct'] / ff['sum_pct'] if ff['sum_pct'] else None, 2)} | "
                      f"{fmt(r['cpu_pct'] / ff['all_four_pct'] if ff['all_four_pct'] else None, 2)} | "
                      f"{fmt(r['wakeups_per_s'] / ff['budget'] if ff['budget'] else None, 2)} |")
        print()
        print("| build | threads: CPU % (wake-ups/s), last round |")
        print("|---|---|")
        for b, r in res["rounds"][-1].items():
            print(f"| {b} | " + " / ".join(f"{t['name']} {t['cpu_pct']:.1f} ({t['wakeups_per_s']:.0f})"
                                           for t in r["threads"] if t["cpu_pct"] > 0.05 or t["wakeups_per_s"] > 1) + " |")
        print()
    if res.get("alone"):
        print("| instrument alone | rate Hz | CPU % before / after | CPU % per 1 k/s before / after | ratio |"
              " wake-ups/s before / after |")
        print("|---|---:|---:|---:|---:|---:|")
        for name, r in res["alone"].items():
            b, a = r["before"], r["after"]
            print(f"| {name} | {a['rate_hz']:.0f} | {b['cpu_pct']:.2f} / {a['cpu_pct']:.2f} | "
                  f"{fmt(b['cpu_pct_per_khz'], 2)} / {fmt(a['cpu_pct_per_khz'], 2)} | "
                  f"{fmt(a['cpu_pct_per_khz'] / b['cpu_pct_per_khz'] if b['cpu_pct_per_khz'] else None, 2)} | "
                  f"{b['wakeups_per_s']:.0f} / {a['wakeups_per_s']:.0f} |")
        print()
    if res.get("side_by_side"):
        rows = res["side_by_side"]
        print("| window (both at once) | gw-io % before / after | process % before / after | samples/s before / after |"
              " load |")
        print("|---|---:|---:|---:|---:|")
        for i, w in enumerate(rows):
            b, a = w["before"], w["after"]
            print(f"| {i + 1} | {b['gw_io_pct']:.2f} / {a['gw_io_pct']:.2f} | {b['cpu_pct']:.2f} / {a['cpu_pct']:.2f} | "
                  f"{b['samples_per_s']:.0f} / {a['samples_per_s']:.0f} | {w['loadavg_1min']:.1f} |")
        tot = {k: {m: sum(w[k][m] for w in rows) for m in ("gw_io_pct", "cpu_pct", "samples_per_s")}
               for k in ("before", "after")}
        per_sample = {k: t["cpu_pct"] / t["samples_per_s"] for k, t in tot.items()}
        print(f"\nafter / before, side by side: gw-io {tot['after']['gw_io_pct'] / tot['before']['gw_io_pct']:.3f}, "
              f"process {tot['after']['cpu_pct'] / tot['before']['cpu_pct']:.3f}, "
              f"process per sample {per_sample['after'] / per_sample['before']:.3f}\n")
    if res.get("side_by_side_latency"):
        sl = res["side_by_side_latency"]
        print(f"Latency side by side (both daemons at once, publishing every batch, {sl['seconds']:g} s, "
              f"load {sl['loadavg_1min']:.1f}):\n")
        print("| device | samples published before / after | median us before / after | p99 us before / after |")
        print("|---|---:|---:|---:|")
        for k in DEVICES:
            b, a = sl["before"][k], sl["after"][k]
            print(f"| {k} | {b['n']} / {a['n']} | {fmt(b['median'])} / {fmt(a['median'])} | "
                  f"{fmt(b['p99'])} / {fmt(a['p99'])} |")
        print()
    if res.get("cyclictest"):
        print(f"cyclictest on CPU {res['cyclictest_cpu']} (SCHED_FIFO 95, 200 us); ratios against the idle run of the "
              "same round:\n")
        print("| round | phase | samples | p99 us | max us | p99 / idle | max / idle |"
              " daemon threads switched in on the CPU /s | emulators' /s | daemon may run on | daemon samples/s |")
        print("|---|---|---:|---:|---:|---:|---:|---:|---:|---|---:|")
        for r in res["cyclictest"]:
            idle = next(x for x in res["cyclictest"] if x["round"] == r["round"] and x["phase"] == "idle")
            rp = r["p99_us"] / idle["p99_us"] if idle.get("p99_us") else None
            rm = r["max_us"] / idle["max_us"] if idle.get("max_us") else None
            print(f"| {r['round']} | {r['phase']} | {r['samples']} | {r['p99_us']} | {r['max_us']} | {fmt(rp, 2)} | "
                  f"{fmt(rm, 2)} | {fmt(r.get('daemon_switches_in_per_s'), 1)} | "
                  f"{fmt(r.get('emulator_switches_in_per_s'), 1)} | {r.get('daemon_cpus_allowed', '')} | "
                  f"{r.get('samples_per_s', '')} |")


if __name__ == "__main__":
    main()
