#!/usr/bin/python3
"""Turns Google Benchmark JSON (--benchmark_format=json) into a Markdown table of throughput with
ratios against the peers. Benchmarks are named GROUP/IMPL[/...]; the implementation called
`guideway` is compared with every other one of its group. With repetitions, the median is used.

    build/bench/ring_bench --benchmark_format=json --benchmark_repetitions=5 > ring.json
    bench/ratios.py ring.json
"""
import json
import statistics
import sys
from collections import defaultdict


def main():
    data = json.load(open(sys.argv[1]))
    rates = defaultdict(list)  # (group, impl) -> items/s samples
    for b in data["benchmarks"]:
        if b.get("run_type") == "aggregate":
            continue
        parts = b["name"].split("/")
        if len(parts) < 2 or "items_per_second" not in b:
            continue
        rates[(parts[0], parts[1])].append(b["items_per_second"])
    groups = defaultdict(dict)
    for (group, impl), values in rates.items():
        groups[group][impl] = statistics.median(values)
    ctx = data.get("context", {})
    print(f"Machine: {ctx.get('num_cpus', '?')} CPUs at {ctx.get('mhz_per_cpu', '?')} MHz, "
          f"host {ctx.get('host_name', '?')}, {ctx.get('date', '')}")
    print()
    print("| benchmark | implementation | M items/s (median) | guideway / this |")
    print("|---|---|---:|---:|")
    for group in sorted(groups):
        impls = groups[group]
        ours = impls.get("guideway")
        for impl in sorted(impls, key=lambda i: (i != "guideway", i)):
            ratio = "" if impl == "guideway" or ours is None else f"{ours / impls[impl]:.2f}x"
            print(f"| {group} | {impl} | {impls[impl] / 1e6:.1f} | {ratio} |")


if __name__ == "__main__":
    main()
