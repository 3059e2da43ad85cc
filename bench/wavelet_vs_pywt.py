#!/usr/bin/python3
"""Guideway's wavelets next to PyWavelets, same machine, same run; prints a Markdown table with the ratios.

    /usr/bin/python3 bench/wavelet_vs_pywt.py [PATH/TO/wavelet_bench] [--min-time S]

Build the benchmark first (Release):
    cmake -S . -B build-rel -G Ninja -DCMAKE_BUILD_TYPE=Release -DGUIDEWAY_BUILD_BENCH=ON && ninja -C build-rel wavelet_bench

Rates are input samples per second of CPU time of the thread (Google Benchmark's items_per_second; PyWavelets
timed with time.process_time), so a loaded machine slows both sides alike. Mode periodization, 5 levels.
PyWavelets' MRA = wavedec + one waverec per band with the other bands zeroed (what a PyWavelets 1.1.1 user
writes: it has no pywt.mra). Memory-bandwidth fraction: bytes that must cross memory per input sample
(read the signal, write the result: 16 B for wavedec/waverec/streaming, 8 + 6*8 = 56 B for a 6-band MRA)
times the rate, over 20 GB/s (this machine's memory copy rate).
"""
import json
import subprocess
import sys
import time

import numpy as np
import pywt

BANDWIDTH = 20e9
LEVELS = 5
WAVELETS = ["db1", "db4", "db8"]
SIZES = [1_000_000, 10_000_000]


def cpu_rate(fn, n, min_time):
    fn()  # warm-up
    reps, start = 0, time.process_time()
    while True:
        fn()
        reps += 1
        elapsed = time.process_time() - start
        if elapsed >= min_time and reps >= 2:
            return n * reps / elapsed


def pywt_rates(min_time):
    out = {}
    rng = np.random.default_rng(1)
    for n in SIZES:
        x = rng.standard_normal(n)
        for w in WAVELETS:
            c = pywt.wavedec(x, w, mode="periodization", level=LEVELS)

            def mra():
                cc = pywt.wavedec(x, w, mode="periodization", level=LEVELS)
                return [pywt.waverec([ci if i == b else np.zeros_like(ci) for i, ci in enumerate(cc)], w,
                                     mode="periodization") for b in range(len(cc))]

            out[("wavedec", w, n)] = cpu_rate(lambda: pywt.wavedec(x, w, mode="periodization", level=LEVELS), n,
                                              min_time)
            out[("waverec", w, n)] = cpu_rate(lambda: pywt.waverec(c, w, mode="periodization"), n, min_time)
            out[("mra", w, n)] = cpu_rate(mra, n, min_time)
    return out


def cpp_rates(binary, min_time):
    p = subprocess.run([binary, "--benchmark_format=json", f"--benchmark_min_time={min_time}"],
                       capture_output=True, text=True, check=True)
    out = {}
    for b in json.loads(p.stdout)["benchmarks"]:
        name = b["name"].split("/")
        kind = name[0].removeprefix("BM_")
        w = WAVELETS[int(name[1])]
        if kind == "streaming":
            key = ("streaming", w, int(name[2]), int(name[3]))
        else:
            key = (kind, w, int(name[2]))
        out[key] = b["items_per_second"]
    return out


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    binary = args[0] if args else "build-rel/bench/wavelet_bench"
    min_time = float(sys.argv[sys.argv.index("--min-time") + 1]) if "--min-time" in sys.argv else 0.5
    cpu = subprocess.run(["sh", "-c", "grep -m1 'model name' /proc/cpuinfo | cut -d: -f2"], capture_output=True,
                         text=True).stdout.strip()
    load = open("/proc/loadavg").read().split()[0]
    cpp = cpp_rates(binary, min_time)
    py = pywt_rates(min_time)
    print(f"CPU: {cpu}; load average at start {load}; PyWavelets {pywt.__version__}, numpy {np.__version__}")
    print()
    print("| operation | wavelet | N | guideway (M samples/s) | PyWavelets (M samples/s) | ratio | target | "
          "memory bandwidth |")
    print("|---|---|---|---|---|---|---|---|")
    targets = {"wavedec": 2.0, "waverec": 2.0, "mra": 10.0}
    nbytes = {"wavedec": 16, "waverec": 16, "mra": 8 + 8 * (LEVELS + 1)}
    for kind in ["wavedec", "waverec", "mra"]:
        for w in WAVELETS:
            for n in SIZES:
                g, p = cpp[(kind, w, n)], py[(kind, w, n)]
                ok = "met" if g / p >= targets[kind] else "MISSED"
                print(f"| {kind} | {w} | {n:.0e} | {g / 1e6:.0f} | {p / 1e6:.0f} | {g / p:.1f}x | "
                      f">= {targets[kind]:.0f}x {ok} | {g * nbytes[kind] / BANDWIDTH:.0%} |")
    for key, g in sorted(cpp.items(), key=lambda kv: str(kv[0])):
        if key[0] != "streaming":
            continue
        _, w, chunk, comps = key
        p = py[("wavedec", w, 1_000_000)]
        what = "streaming decomposition" + (" + MRA" if comps else "")
        ok = "met" if g >= p else "MISSED"
        print(f"| {what}, chunks of {chunk} | {w} | 1e+06 | {g / 1e6:.0f} | {p / 1e6:.0f} (batch wavedec) | "
              f"{g / p:.1f}x | >= 1x {ok} | {g * 16 / BANDWIDTH:.0%} |")


if __name__ == "__main__":
    main()
