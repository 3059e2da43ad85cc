#!/usr/bin/python3
"""The ballbar diagnostics of the demo's gappy live session (tests/data/demo_gaps: 9 and 38 gaps, most of
the CW run's around X's reversal) against the machine file and against numpy.

- `guideway identify dbb --json` on the two run files: every diagnostics term of config/machine-example.toml
  within 3 u of it, the backlash determined (not contradicting EXPLAIN) and within 3 combined u of Lai's.
- numpy's weighted least squares of the diagnostics' columns written here from docs/conventions.md (centre
  per run, scales, squareness, the backlash deadband of its own width, play, servo mismatch, bows, the cubic
  straightness difference, the spikes at the decay identify searched; each run weighted by the arc its
  samples hold) on the same files: every term agrees within a hundredth of its u (measured: at most 3e-3 u,
  the deadband's width being a fixed point identify stops within 2 %).

usage: dbb_gaps_cli_test.py BUILD_DIR SOURCE_DIR
"""
import json
import os
import subprocess
import sys

import numpy as np

BUILD, SOURCE = sys.argv[1], sys.argv[2]
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")
FILES = [os.path.join(SOURCE, "tests", "data", "demo_gaps", f) for f in ("live_1_ccw.csv", "live_2_cw.csv")]

# config/machine-example.toml at r = 100 mm, h = 0: both axes lag 30 ms (12.5 ppm of radius in both scales).
TRUTH = {
    "scale_mismatch_ppm": -20.0, "squareness_urad": 30.0, "backlash_x_um": 1.0, "backlash_y_um": 2.0,
    "lateral_play_x_um": 0.0, "lateral_play_y_um": 0.0, "servo_mismatch_ms": 0.0,
    "straightness_x_um": 2.25, "straightness_y_um": 2.5, "straightness_cubic_x_minus_y_um": -10.0,
    "reversal_spike_x_um": 0.0, "reversal_spike_y_um": 0.0,
    "run1.center_offset_x_um": 2.0, "run1.center_offset_y_um": -3.0,
    "run2.center_offset_x_um": 2.0, "run2.center_offset_y_um": -3.0,
}


def read_run(path):
    meta = {}
    with open(path) as f:
        lines = f.read().splitlines()
    for line in lines:
        if line.startswith("#") and "=" in line:
            k, v = line[1:].split("=", 1)
            meta[k.strip()] = v.strip()
    first = next(i for i, l in enumerate(lines) if not l.startswith("#"))
    return meta, np.loadtxt(lines[first + 1:], delimiter=",", ndmin=2)


def since_reversal_rad(zeta, phase, sense):
    """Angle travelled since the axis last reversed (at zeta = phase + k pi), in [0, pi)."""
    q = (zeta - phase) / np.pi
    return np.abs(zeta - phase - (np.floor(q) if sense > 0 else np.ceil(q)) * np.pi)


def lost_motion(sgn, rise_m, width_m):
    """Per unit backlash: the deadband of width_m, taken up as the drive rises from its extreme."""
    return -sgn * np.clip(rise_m / width_m - 0.5, -0.5, 0.5) if width_m > 0 else -0.5 * sgn


def numpy_fit(spike):
    """Weighted least squares of the diagnostics' columns (docs/conventions.md's signatures): the backlash as
    the deadband of its own estimate (iterated from the ideal step), the spikes with the decay and delay
    identify searched (`spike`: per axis (tau_s, delay_s)), no cyclic error (none was found)."""
    runs = [read_run(f) for f in FILES]
    n_total = sum(len(d) for _, d in runs)
    # A run with gaps weighs by the arc it holds (identify's points_of): a gap is a step over
    # max(5 median steps, 0.5 deg) (formats::dbb_run_gaps) and keeps one step of its arc.
    covered = []
    for _, d in runs:
        dz = np.abs(np.diff(np.radians(d[:, 1])))
        step = np.median(dz)
        gap = dz > max(5 * step, np.radians(0.5))
        covered.append(np.sum(dz) + step - np.sum(dz[gap] - step))
    widths = (0.0, 0.0)
    for _ in range(6):
        rows, ys, ws = [], [], []
        for k, (meta, d) in enumerate(runs):
            r = float(meta["radius_mm"]) * 1e-3
            sense = 1.0 if meta["direction"] == "ccw" else -1.0
            v = float(meta["feed_mm_per_min"]) / 60e3
            omega = v / r
            z = np.radians(d[:, 1])
            c, s = np.cos(z), np.sin(z)
            sa, sb = -sense * np.sign(s), sense * np.sign(c)
            phi_a, phi_b = since_reversal_rad(z, 0, sense), since_reversal_rad(z, np.pi / 2, sense)
            rise_a, rise_b = 2 * r * np.sin(phi_a / 2) ** 2, 2 * r * np.sin(phi_b / 2) ** 2

            def decay(phi, tau, delay):
                t = phi / omega - delay
                return np.where((t >= 0) & (t <= 8 * tau), np.exp(-np.clip(t, 0, None) / tau), 0.0)

            centre = [(c if i == 0 else s) * (j == k) for j in range(len(runs)) for i in (0, 1)]
            cols = centre + [r * c * c, r * s * s, r * s * c, lost_motion(sa, rise_a, widths[0]) * c,
                             lost_motion(sb, rise_b, widths[1]) * s, 0.5 * sa * s, 0.5 * sb * c,
                             sense * v * s * c * 1e3, s * c * c, c * s * s, 0.5 * s * c * (c * c - s * s),
                             c * -sa * decay(phi_a, *spike[0]), s * -sb * decay(phi_b, *spike[1])]
            rows.append(np.array(cols).T)
            ys.append(d[:, 2])
            share = covered[k] * len(runs) / sum(covered)
            ws.append(np.full(len(d), share * n_total / (len(runs) * len(d))))
        a, y, w = np.vstack(rows), np.concatenate(ys), np.concatenate(ws)
        sw = np.sqrt(w)
        x, *_ = np.linalg.lstsq(a * sw[:, None], y * sw, rcond=None)
        widths = (max(x[7], 0) * 1e-6, max(x[8], 0) * 1e-6)  # the backlash (um) as the width (m)
    names = ["run1.center_offset_x_um", "run1.center_offset_y_um", "run2.center_offset_x_um",
             "run2.center_offset_y_um", "scale_x_ppm", "scale_y_ppm", "squareness_urad", "backlash_x_um",
             "backlash_y_um", "lateral_play_x_um", "lateral_play_y_um", "servo_mismatch_ms", "straightness_x_um",
             "straightness_y_um", "straightness_cubic_x_minus_y_um", "reversal_spike_x_um", "reversal_spike_y_um"]
    return dict(zip(names, x))


def main():
    out = subprocess.run([GUIDEWAY, "identify", "dbb", *FILES, "--json"], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    j = json.loads(out.stdout)
    diag, lai = j["diagnostics"], j["lai3"]
    failures = []
    for name, truth in TRUTH.items():
        e = diag.get(name)
        if e is None or "u" not in e or "not_determined" in e:
            failures.append(f"{name}: not fitted ({e})")
            continue
        z = abs(e["value"] - truth) / e["u"]
        print(f"{name:34s} {e['value']:10.4f} ± {e['u']:.4f}  truth {truth:7.3f}  ({z:.1f} u)")
        if z > 3:
            failures.append(f"{name}: {e['value']:.4f} ± {e['u']:.4f}, truth {truth} ({z:.1f} u)")
    for axis in ("x", "y"):
        d, l = diag[f"backlash_{axis}_um"], lai[f"backlash_{axis}_um"]
        if abs(d["value"] - l["value"]) > 3 * np.hypot(d["u"], l["u"]):
            failures.append(f"backlash {axis}: diagnostics {d['value']:.4f} ± {d['u']:.4f}, Lai {l['value']:.4f}")
    if any("not determined" in n for n in j["notes"]):
        failures.append("a diagnostic is not determined: " + "; ".join(j["notes"]))
    if "cyclic_period_x_mm" in diag or "cyclic_period_y_mm" in diag:
        failures.append("a cyclic error was fitted (the machine has none; numpy's columns hold none)")
    spike = [(diag[f"reversal_spike_decay_{a}_ms"]["value"] * 1e-3, diag[f"reversal_spike_delay_{a}_ms"]["value"] * 1e-3)
             for a in ("x", "y")]
    ref = numpy_fit(spike) if not failures else {}
    for name in ref:
        e = diag.get(name)
        if e is None or "u" not in e:
            continue  # said above
        print(f"numpy {name:34s} {ref[name]:10.4f}, identify {e['value']:10.4f} (u {e['u']:.4f}, apart {abs(ref[name] - e['value']) / e['u']:.1e} u)")
        if abs(ref[name] - e["value"]) > 0.01 * e["u"]:
            failures.append(f"{name}: identify {e['value']:.5f}, numpy {ref[name]:.5f}, more than u/100 apart")
    assert not failures, "\n".join(failures)
    print("dbb_gaps_cli_test: ok")


if __name__ == "__main__":
    main()
