#!/usr/bin/env python3
"""Light on the controller PC (bench/README.md, "On the controller PC"): guidewayd at the four
instruments' full rates against the platform floor, before and after, in one run; then cyclictest on
one CPU with and without the daemon on the other. Standard library only (plus perf and cyclictest).

  python3 bench/controller_load.py AFTER_BUILD BEFORE_BUILD [--rounds 2] [--step-s 6] [--cyclictest-s 15]
      [--cyclictest-rounds 2] [--skip floor,daemons,alone,cyclictest] [--json out.json]

AFTER_BUILD and BEFORE_BUILD each hold daemon/guidewayd and the emulators (guideway_runtime); the floor
comes from AFTER_BUILD/bench/platform_floor_bench. In order:
  1. the floor: platform_floor_bench's DbbReaderFloor (one thread waking every 900 us, taking the DBB's
     40 k frames/s off the socket and doing nothing else), CPU % of a core;
  2. `rounds` rounds of the two daemons, alternately first, each as bench/daemon_load.py measures a step
     (--rates 10000 --dbb-sync listen --micrometer buffered): CPU at sample_publish_hz 10, wake-ups/s
     (voluntary context switches of every thread, /proc), p99 sample-to-publish latency publishing
     every batch, losses;
  3. each instrument alone at its full rate in a daemon of each build: CPU per 1 k samples/s;
  3b. with --side-by-side N: both daemons at once, under the same load, gw-io's and the process's CPU
     over N windows of --step-s (on a machine others load, the one comparison of the builds that holds);
  4. cyclictest (SCHED_FIFO 95, 200 us interval) pinned to the last CPU: alone, beside the "after"
     daemon kept off that CPU (the kernel's isolated list stood in for by $GUIDEWAY_CPU_ISOLATED_FILE),
     beside it spread over every CPU, and beside the "before" daemon, `--cyclictest-rounds` times in
     turn; p99 and max latency, and the daemon's threads switched in on the measured CPU (perf,
     sched:sched_switch). The emulators are the daemon's children: they run where it may.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import daemon_load as dl  # noqa: E402

DEVICES = ("dbb", "autocollimator", "micrometer", "profilometer")


def floor(build, repetitions):
    """platform_floor_bench's DbbReaderFloor at 900 us with timestamps: core % per run."""
    exe = f"{build}/bench/platform_floor_bench"
    out = subprocess.run([exe, "--benchmark_filter=DbbReaderFloor/period_us:900/timestamps:1",
                          f"--benchmark_repetitions={repetitions}", "--benchmark_format=json"],
                         capture_output=True, text=True, check=True).stdout
    runs = [b for b in json.loads(out)["benchmarks"] if b.get("run_type") == "iteration"]
    return [round(b["core_pct"], 2) for b in runs]


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


def side_by_side(builds, windows):
    """Both daemons at full rate at once: per window, each one's gw-io and process CPU % and samples/s."""
    ds, conns, tids = {}, {}, {}
    try:
        for b, path in builds.items():
            ds[b] = dl.Daemon(path, dl.step_rates(10000), publish_hz=10, client_queue_bytes=4 << 20)
        for b, d in ds.items():
            conns[b] = dl.Conn(d.socket)
            d.wait_streaming(conns[b])
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
    ap.add_argument("--json", help="write the raw results here")
    ARGS = ap.parse_args()
    dl.DBB_SYNC = "listen"
    dl.MICROMETER["mode"] = "buffered"
    skip = set(ARGS.skip.split(",")) - {""}
    builds = {"before": ARGS.before, "after": ARGS.after}
    res = {"machine": dl.machine(), "load_before": dl.loadavg(), "builds": builds}
    if "floor" not in skip:
        print("floor ...", file=sys.stderr, flush=True)
        res["floor_pct"] = floor(ARGS.after, ARGS.floor_repetitions)
    if "daemons" not in skip:
        res["rounds"] = []
        for r in range(ARGS.rounds):
            order = ("before", "after") if r % 2 == 0 else ("after", "before")
            row = {}
            for b in order:
                print(f"round {r + 1}: {b} ...", file=sys.stderr, flush=True)
                row[b] = daemon_round(builds[b])
            res["rounds"].append(row)
        if "floor" not in skip:  # the floor again after the daemons: the machine may have changed meanwhile
            res["floor_pct_after"] = floor(ARGS.after, ARGS.floor_repetitions)
    if "alone" not in skip:
        res["alone"] = {}
        for name in DEVICES:
            for b in ("before", "after"):
                print(f"{name} alone: {b} ...", file=sys.stderr, flush=True)
                res["alone"].setdefault(name, {})[b] = alone(builds[b], name)
    if ARGS.side_by_side > 0:
        print(f"side by side, {ARGS.side_by_side} windows ...", file=sys.stderr, flush=True)
        res["side_by_side"] = side_by_side(builds, ARGS.side_by_side)
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
    if floors:
        print(f"Floor (DbbReaderFloor, 900 us, timestamps): {', '.join(fmt(x, 2) for x in floors)} % of a core; "
              f"median {fmt(fl, 2)} %\n")
    if res.get("rounds"):
        print("| round | build | samples/s | CPU % | x floor | wake-ups/s | p99 us (all) | p99 us dbb / ac / mic / prof |"
              " losses | load |")
        print("|---|---|---:|---:|---:|---:|---:|---|---:|---:|")
        for i, row in enumerate(res["rounds"]):
            for b, r in row.items():
                by = r["p99_us_by_device"]
                print(f"| {i + 1} | {b} | {r['samples_per_s']:.0f} | {r['cpu_pct']:.1f} | "
                      f"{fmt(r['cpu_pct'] / fl if fl else None, 2)} | {r['wakeups_per_s']:.0f} | {fmt(r['p99_us'])} | "
                      + " / ".join(fmt(by.get(k)) for k in DEVICES) + f" | {sum(r['losses'].values())} | "
                      f"{r['loadavg_1min']:.1f} |")
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
