#!/usr/bin/env python3
"""How often EXPLAIN finds an autocollimator's drift beside the reflector's rocking, against the expected t.

Usage: scripts/traverse_drift_detection.py build/cli/guideway [--seeds 100] [--passes 2] [--dwell-s 2]
                                           [--drift 0.1] [--rocking 0.2] [--noise 0.05] [--stations 33]

Writes traverses as the straightness session derives them (stations 18.75 mm apart, forward and back, a
reading every dwell s, each with its t_s and pass; a smooth pitch curve, a drift in "/min, a rocking in ",
normal noise in " a reading from numpy's generator seeded 1..N), explains each with
`guideway explain --model traverse`, and counts the seeds at which angle_drift is found, beside what the
design predicts: the drift's u from the least squares of the base polynomial, the rocking and the drift,
its expected t, and the chance that the F-test passes at alpha = 1e-3 over the 3 candidates left once
the rocking is taken (docs/explain.md, "A drift's detection limit").
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
from scipy import stats


def readings(passes, dwell_s, stations, step_mm, drift, rocking, noise, rng):
    t = 0.0
    for p in range(passes):
        d = 1 if p % 2 == 0 else -1
        for k in range(stations) if d > 0 else range(stations - 1, -1, -1):
            x_mm = k * step_mm
            xi = (x_mm + step_mm / 2) / (stations * step_mm)
            pitch = 2.0 * xi - 1.5 * xi**2 + drift * t / 60 + rocking * d + rng.normal(0, noise)
            yaw = 0.5 * xi + rng.normal(0, noise)
            yield x_mm, pitch, yaw, t, p + 1, d
            t += dwell_s


def predicted(a):
    """The drift's u ("/min), expected t, F-test threshold on |t| and chance of passing it."""
    rows = []
    span = a.stations * 18.75
    for x_mm, _, _, t, _, d in readings(a.passes, a.dwell_s, a.stations, 18.75, 0, 0, 0, np.random.default_rng(0)):
        xi, s = x_mm / span, 18.75 / span
        rows.append([((xi + s) ** j - xi**j) / s for j in range(1, 4)] + [d, t / 60])
    x = np.array(rows)
    u = a.noise * np.sqrt(np.linalg.inv(x.T @ x)[-1, -1])
    dof = len(x) - x.shape[1]
    t_crit = stats.t.isf(1e-3 / 3 / 2, dof)
    t_exp = a.drift / u
    return u, t_exp, t_crit, stats.nct.sf(t_crit, dof, t_exp) + stats.nct.cdf(-t_crit, dof, t_exp)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("guideway")
    ap.add_argument("--seeds", type=int, default=100)
    ap.add_argument("--passes", type=int, default=2)
    ap.add_argument("--dwell-s", type=float, default=2.0)
    ap.add_argument("--drift", type=float, default=0.1)
    ap.add_argument("--rocking", type=float, default=0.2)
    ap.add_argument("--noise", type=float, default=0.05)
    ap.add_argument("--stations", type=int, default=33)
    a = ap.parse_args()
    found, verdicts = 0, {}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(1, a.seeds + 1):
            path = os.path.join(tmp, "traverse.csv")
            with open(path, "w") as f:
                f.write("# step_mm = 18.75\nx_mm,pitch_arcsec,yaw_arcsec,t_s,pass\n")
                rng = np.random.default_rng(seed)
                for x_mm, pitch, yaw, t, p, _ in readings(a.passes, a.dwell_s, a.stations, 18.75, a.drift, a.rocking,
                                                          a.noise, rng):
                    f.write("%g,%.4f,%.4f,%g,%d\n" % (x_mm, pitch, yaw, t, p))
            run = subprocess.run([a.guideway, "explain", "--model", "traverse", path, "--json", "--quiet"],
                                 capture_output=True, text=True)
            if run.returncode != 0 and not run.stdout:
                verdicts["failed: " + run.stderr.strip()] = verdicts.get("failed: " + run.stderr.strip(), 0) + 1
                continue
            report = json.loads(run.stdout)
            if any(f["effect"] == "angle_drift" for f in report["findings"]):
                found += 1
                continue
            why = [c["verdict"].split(" (")[0] for c in report["considered"] if c["effect"] == "angle_drift"]
            key = why[0] if why else "not a candidate"
            key = "removes only N % of the structure left without it" if key.startswith("removes only") else key
            verdicts[key] = verdicts.get(key, 0) + 1
    u, t_exp, t_crit, p = predicted(a)
    print(f'{a.passes} passes, {a.dwell_s:g} s a station: drift {a.drift:g}"/min, u {u:.4f}"/min, expected t '
          f"{t_exp:.2f} against |t| > {t_crit:.2f}: predicted found {100 * p:.0f} %; found at {found} of {a.seeds} seeds")
    for why, n in sorted(verdicts.items(), key=lambda kv: -kv[1]):
        print(f"  missed at {n}: {why}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
