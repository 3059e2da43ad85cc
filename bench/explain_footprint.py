#!/usr/bin/python3
"""EXPLAIN's footprint: CPU and peak RSS of the process for each case of issue 45's table, two `guideway`
binaries (before / after) alternating case by case in one run, so both see the same machine load; the
results of the two compared (bench/README.md "EXPLAIN's footprint").

    bench/explain_footprint.py BEFORE/guideway AFTER/guideway --cases-tool AFTER_BUILD/bench/explain_footprint_cases
    bench/explain_footprint.py B A --cases-tool T --rounds 3 --only slip_18859 --only traverse

CPU is the child's user + system time, peak RSS its ru_maxrss (getrusage of the process, as /usr/bin/time
reports it). The inputs are written once into --dir (default a temporary directory) by explain_footprint_cases
(the DBB and run-out cases, traced by the virtual machine tool) and from tests/data/dabam/dabam-072.dat (the traverse:
a real 9,230-reading slope profile read forward, then back with fresh noise; and the same with a reflector rocking
of 1x its slope RMS; the traverse cases alone need no --cases-tool). Each row of the output gives the
medians over the rounds and after / before; the load average is printed per case. Every case's --json output of
the two binaries is compared: "results" says whether every number agrees to 1e-9 relative (and every text
exactly), else the first differences.
"""
import argparse
import json
import math
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
ARCSEC_PER_RAD = 180 / math.pi * 3600


def write_traverse(path, rocking=0.0, dabam=os.path.join(ROOT, "tests", "data", "dabam", "dabam-072.dat")):
    """Two passes of DABAM entry 72 (ESRF, 9,230 slopes at 0.105 mm) as a traverse file: forward as measured,
    then the return over the same stations with 10 % of the profile's slope RMS of fresh noise; 2 s a
    station, 10 s between the passes; with `rocking`, a reflector rocking of that many slope RMS (+ forward,
    - back). Positions on the exact grid of its mean step (the file's jitter is below 1e-6 of a step)."""
    meta = json.load(open(dabam[:-4] + ".txt"))
    rows = [line.split() for line in open(dabam).read().splitlines()[meta["FILE_HEADER_LINES"]:] if line.strip()]
    x = [float(r[0]) * meta["X1_FACTOR"] for r in rows]
    slope = [float(r[1]) * meta["Y1_FACTOR"] for r in rows]
    step = (x[-1] - x[0]) / (len(x) - 1)
    mean = sum(slope) / len(slope)
    rms = math.sqrt(sum((s - mean) ** 2 for s in slope) / len(slope))
    rng = random.Random(45)
    n = len(slope)
    with open(path, "w") as f:
        f.write(f"# step_mm = {step * 1e3:.17g}\n# source = DABAM entry 72 (tests/data/dabam), forward then back\n")
        f.write("x_mm,pitch_arcsec,t_s,pass\n")
        t = 0.0
        for k in range(n):
            f.write(f"{k * step * 1e3:.17g},{(slope[k] + rocking * rms) * ARCSEC_PER_RAD:.17g},{t:.17g},1\n")
            t += 2.0
        t += 8.0
        for k in reversed(range(n)):
            s = slope[k] + rng.gauss(0.0, 0.1 * rms) - rocking * rms
            f.write(f"{k * step * 1e3:.17g},{s * ARCSEC_PER_RAD:.17g},{t:.17g},2\n")
            t += 2.0
    return n


def cases(d):
    """(name, what, arguments of guideway) for each case, the inputs under d."""
    runs = lambda c: sorted(os.path.join(d, c, f) for f in os.listdir(os.path.join(d, c))) \
        if os.path.isdir(os.path.join(d, c)) else []
    out = [
        ("dbb_four", "`explain --model dbb`, four effects, 2 runs (2 x 15,717)",
         ["explain", "--model", "dbb", *runs("dbb_four")]),
        ("identify_four", "the same through `identify dbb` (checked by EXPLAIN) (2 x 15,717)",
         ["identify", "dbb", *runs("dbb_four")]),
        ("null_dense", "a null on a dense record (2 x 37,709)", ["explain", "--model", "dbb", *runs("dbb_null_dense")]),
        ("slip_18859", "backlash beside a ball slip (2 x 18,859)", ["explain", "--model", "dbb", *runs("dbb_slip_18859")]),
        ("runout", "run-out, three effects (7,200)", ["explain", "--model", "runout", *runs("runout_three")]),
        ("traverse", "a real 9,230-reading profile as two passes (18,460)",
         ["explain", "--model", "traverse", os.path.join(d, "traverse", "dabam072_two_passes.csv")]),
        ("traverse_rocking", "the same with a reflector rocking of 1x its slope RMS (18,460)",
         ["explain", "--model", "traverse", os.path.join(d, "traverse", "dabam072_two_passes_rocking.csv")]),
    ]
    for n in (3600, 7200, 36000):
        out.append((f"slip_{n}", f"backlash beside a ball slip (2 x {n:,})",
                    ["explain", "--model", "dbb", *runs(f"dbb_slip_{n}")]))
    return out


def run(binary, args):
    """CPU (s), peak RSS (MB) and stdout of one process."""
    with tempfile.TemporaryFile() as out:
        p = subprocess.Popen([binary, *args, "--json", "--quiet"], stdout=out, stderr=subprocess.DEVNULL)
        _, status, ru = os.wait4(p.pid, 0)
        out.seek(0)
        text = out.read().decode()
    if os.waitstatus_to_exitcode(status) != 0:
        raise RuntimeError(f"{binary} {' '.join(args)} exited {os.waitstatus_to_exitcode(status)}")
    return ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024.0, text


def differences(a, b, where="", out=None, rel=1e-9):
    """Where two JSON values differ: numbers beyond rel (relative), anything else at all."""
    out = [] if out is None else out
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                out.append(f"{where}/{k}: only in one")
            else:
                differences(a[k], b[k], f"{where}/{k}", out, rel)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{where}: {len(a)} against {len(b)} items")
        for i, (x, y) in enumerate(zip(a, b)):
            differences(x, y, f"{where}[{i}]", out, rel)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        if not (a == b or abs(a - b) <= rel * max(abs(a), abs(b)) or (math.isnan(a) and math.isnan(b))):
            out.append(f"{where}: {a!r} against {b!r}")
    elif a != b:
        out.append(f"{where}: {str(a)[:80]!r} against {str(b)[:80]!r}")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("before")
    ap.add_argument("after")
    ap.add_argument("--cases-tool", help="explain_footprint_cases of a build (for every case but the traverses)")
    ap.add_argument("--dir", help="where the inputs are (written when missing)")
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--only", action="append", help="these cases only (repeatable)")
    o = ap.parse_args()
    d = o.dir or tempfile.mkdtemp(prefix="explain_footprint_")
    traverses_only = o.only and all(name.startswith("traverse") for name in o.only)
    if not os.path.isdir(os.path.join(d, "dbb_four")) and not traverses_only:
        if not o.cases_tool:
            ap.error("--cases-tool is needed for the DBB and run-out cases")
        subprocess.run([o.cases_tool, d, os.path.join(ROOT, "config", "machine-example.toml")], check=True,
                       stdout=subprocess.DEVNULL)
    for name, rocking in (("dabam072_two_passes.csv", 0.0), ("dabam072_two_passes_rocking.csv", 1.0)):
        traverse = os.path.join(d, "traverse", name)
        if not os.path.exists(traverse):
            os.makedirs(os.path.dirname(traverse), exist_ok=True)
            write_traverse(traverse, rocking)
    print(f"inputs in {d}; before {o.before}; after {o.after}; {o.rounds} round(s), the order swapped each case")
    print()
    print("| case | before: CPU | after: CPU | after / before | before: peak RSS | after: peak RSS | after / before "
          "| load | results |")
    print("|---|---|---|---|---|---|---|---|---|")
    for i, (name, what, args) in enumerate(cases(d)):
        if o.only and name not in o.only:
            continue
        load0 = os.getloadavg()[0]
        got = {"before": [], "after": []}
        texts = {}
        for r in range(o.rounds):
            order = ["before", "after"] if (i + r) % 2 == 0 else ["after", "before"]
            for which in order:
                cpu, rss, text = run(getattr(o, which), args)
                got[which].append((cpu, rss))
                texts[which] = text
        load1 = os.getloadavg()[0]
        med = {w: (statistics.median(c for c, _ in v), statistics.median(m for _, m in v)) for w, v in got.items()}
        diff = differences(json.loads(texts["before"]), json.loads(texts["after"]))
        results = "same" if not diff else f"{len(diff)} differ: " + "; ".join(diff[:3])
        cpu_b, rss_b = med["before"]
        cpu_a, rss_a = med["after"]
        print(f"| {what} | {cpu_b:.2f} s | {cpu_a:.2f} s | {cpu_a / cpu_b:.2f} | {rss_b:.0f} MB | {rss_a:.0f} MB | "
              f"{rss_a / rss_b:.2f} | {load0:.1f}-{load1:.1f} | {results} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
