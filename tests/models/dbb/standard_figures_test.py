#!/usr/bin/python3
"""The standards' figures of a circular test (docs/standards.md) against an independent numpy
computation on simulated runs of the virtual machine:

- an XY pair of full circles (r 100 mm, CCW and CW; one run carries `temperature_c`), and an XZ pair of
  220 deg arcs (CCW from -20 deg, CW from 200 deg);
- per run: ISO 230-4 G and F max/min (least-squares circle by numpy's lstsq), ASME B5.54 circularity;
- per pair: H and G(b) about the pair's common least-squares circle (H on a 0.5 deg grid by np.interp over
  the angles both runs hold), and their ASME B5.54 twins;
- the test conditions in the JSON and the CLI text, "not recorded" where the run does not say, and the
  partial arc's figures labelled as over its arc.

usage: standard_figures_test.py BUILD_DIR SOURCE_DIR
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

BUILD, SOURCE = sys.argv[1], sys.argv[2]
GUIDEWAY = os.path.join(BUILD, "cli", "guideway")
MACHINE = os.path.join(SOURCE, "tests", "models", "dbb", "dbb_three_planes_machine.toml")


def run(*args):
    out = subprocess.run([GUIDEWAY, *args], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, f"guideway {' '.join(args)}: {out.stderr}"
    return out.stdout


def load(path):
    """(metadata, angle_rad, dL_um) of a run file, read here."""
    with open(path) as f:
        lines = f.read().splitlines()
    meta = {}
    for line in lines:
        if line.startswith("#") and "=" in line:
            k, v = line[1:].split("=", 1)
            meta[k.strip()] = v.strip()
    first = next(i for i, l in enumerate(lines) if not l.startswith("#"))
    data = np.loadtxt([l for l in lines[first + 1:] if not l.startswith("#")], delimiter=",", ndmin=2)
    return meta, np.radians(data[:, 1]), data[:, 2]


def circle(angle, y):
    """Least-squares circle: (mean, residuals)."""
    a = np.column_stack([np.ones_like(angle), np.cos(angle), np.sin(angle)])
    x, *_ = np.linalg.lstsq(a, y, rcond=None)
    return x[0], y - a @ x


def on_grid(angle, res):
    """res on the 0.5 deg grid, NaN outside the run's span (no gaps in these runs)."""
    order = np.argsort(angle)
    a, r = angle[order], res[order]
    full = a[-1] - a[0] > np.radians(359)
    grid = np.radians(np.arange(720) * 0.5)
    if full:
        return np.interp(grid, np.mod(a, 2 * np.pi), r, period=2 * np.pi)
    out = np.full(grid.size, np.nan)
    for shift in (-2 * np.pi, 0.0, 2 * np.pi):
        g = grid + shift
        inside = (g >= a[0]) & (g <= a[-1])
        out[inside] = np.interp(g[inside], a, r)
    return out


def close(got, want, what, tol=1e-6):
    assert abs(got - want) <= tol * max(1.0, abs(want)), f"{what}: {got!r}, numpy {want!r}"


def check_identification(j, files, text, partial):
    st = j["standards"]
    assert len(st["runs"]) == 2 and len(st["pairs"]) == 1, st
    loaded = [load(f) for f in files]
    for k, (meta, angle, y) in enumerate(loaded):
        r = st["runs"][k]
        m, dev = circle(angle, y)
        close(r["iso_circular_deviation_um"]["value"], dev.max() - dev.min(), f"run {k + 1} G")
        close(r["iso_radial_deviation_max_um"]["value"], m + dev.max(), f"run {k + 1} F max")
        close(r["iso_radial_deviation_min_um"]["value"], m + dev.min(), f"run {k + 1} F min")
        close(r["asme_circularity_um"]["value"], dev.max() - dev.min(), f"run {k + 1} ASME circularity")
        c = r["conditions"]
        assert c["radius_mm"] == 100 and c["feed_mm_per_min"] == 1000 and c["samples"] == angle.size, c
        assert c["direction"] == meta["direction"] and c["partial_arc"] == partial, c
        close(c["spacing_deg"], np.degrees(np.median(np.abs(np.diff(angle)))), "spacing", 1e-9)
        assert c["feed_in_deg"] == 45 and c["feed_out_deg"] == 45, c
        want_t = float(meta["temperature_c"]) if "temperature_c" in meta else "not recorded"
        assert c["temperature_c"] == want_t, c
        assert r["over"] == ("the 220 deg arc" if partial else "the full circle"), r["over"]
    (_, a1, y1), (_, a2, y2) = loaded
    _, dev = circle(np.concatenate([a1, a2]), np.concatenate([y1, y2]))
    g1, g2 = on_grid(a1, dev[:a1.size]), on_grid(a2, dev[a1.size:])
    both = np.isfinite(g1) & np.isfinite(g2)
    p = st["pairs"][0]
    close(p["iso_circular_hysteresis_um"]["value"], np.max(np.abs(g1 - g2)[both]), "H", 1e-6)
    close(p["asme_hysteresis_um"]["value"], np.max(np.abs(g1 - g2)[both]), "ASME hysteresis", 1e-6)
    close(p["iso_bidirectional_deviation_um"]["value"], dev.max() - dev.min(), "G(b)")
    close(p["asme_bidirectional_circularity_um"]["value"], dev.max() - dev.min(), "ASME bidirectional")
    assert abs(p["common_arc_deg"] - 0.5 * both.sum()) < 1e-9, p
    close(j["diagnostics"]["circular_hysteresis_um"]["value"], p["iso_circular_hysteresis_um"]["value"], "H diag", 1e-12)
    # The CLI text: each figure with its conditions; a partial arc's over its arc.
    assert "the standards' figures" in text, text
    assert "ISO 230-4 circular deviation G" in text and "ASME B5.54 bidirectional circularity" in text, text
    assert "feed-in 45 deg, feed-out 45 deg" in text, text
    assert "temperature not recorded" in text, text
    assert ("over the 220 deg arc" if partial else "over the full circle") in text, text


def main():
    with tempfile.TemporaryDirectory() as tmp:
        xy = [os.path.join(tmp, f"xy-{d}.csv") for d in ("ccw", "cw")]
        run("simulate", "dbb", "--machine", MACHINE, "--radius-mm", "100", "--direction", "ccw", "--out", xy[0])
        run("simulate", "dbb", "--machine", MACHINE, "--radius-mm", "100", "--direction", "cw", "--out", xy[1])
        with open(xy[0]) as f:
            body = f.read()
        with open(xy[0], "w") as f:
            f.write("# temperature_c = 20.4\n" + body)
        xz = [os.path.join(tmp, f"xz-{d}.csv") for d in ("ccw", "cw")]
        for path, d, start in ((xz[0], "ccw", "-20"), (xz[1], "cw", "200")):
            run("simulate", "dbb", "--machine", MACHINE, "--radius-mm", "100", "--plane", "xz", "--direction", d,
                "--arc-deg", "220", "--start-deg", start, "--out", path)
        for files, partial in ((xy, False), (xz, True)):
            j = json.loads(run("identify", "dbb", *files, "--json"))
            check_identification(j, files, run("identify", "dbb", *files), partial)
        text = run("identify", "dbb", *xy)
        assert "temperature 20.4 \u00b0C" in text, text
    print("standard figures: ok")


if __name__ == "__main__":
    main()
